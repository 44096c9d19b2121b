// The value kernel of field_eval.comp shaped for CPU Vulkan implementations (lavapipe), where a
// subgroup is the SIMD register: field.cpp picks it on a CPU device whose compute subgroups are
// LANES invocations wide, and runs a workgroup of exactly one subgroup.
//
// Why: llvmpipe turns every load whose address is not a compile-time constant into a per-lane
// gather, which held field_eval.comp (activations in per-invocation arrays at loop-counter
// indices, weights at loop-counter offsets) to ~11 GFLOP/s. Here nothing in the point loop is
// loaded at a computed address. The subgroup evaluates one point at a time, each lane owning the
// rows r * LANES + lane of every layer: its rows' weights are loaded once per workgroup into
// private arrays read only at constant indices (so they become registers and stack slots), and
// the layer's input i, owned by lane i % LANES, reaches every lane through subgroupShuffle from
// a constant lane (a register shuffle). The points of a workgroup (LANES * POINTS of them) share
// those loads; each lane reads one point of every LANES and shuffles it to the others.
// subgroupBroadcast gives the same values but Mesa 22.3 builds it as a loop over the lanes:
// 3.6x slower. Measured on 2-core lavapipe: bench/RESULTS.md, "0.13.13".
//
// Each output is summed as field_eval.comp sums it: the bias, then per input vec4, in its column
// order (layer 0: the encoding as field.cpp uploads it), the dot product of four weights with four
// inputs. So the values are field_eval.comp's bit for bit, as nfd_asset_evaluate_gradient's (the
// WITH_GRADIENT variant's forward pass) must equal nfd_asset_evaluate's. A hidden layer's input c
// is the previous layer's row c (slot c / LANES of lane c % LANES); the encoding's sines come from
// the lane that computed their (frequency, axis) pair, both sine and cosine of one sincos: three a
// lane at L = 8 rather than the seven that one column per lane and slot would take (6-16% faster
// at widths 16-48).
#version 450
#extension GL_GOOGLE_include_directive : require
#extension GL_EXT_control_flow_attributes : require
#extension GL_KHR_shader_subgroup_shuffle : require
#include "common.glsl"
#define COUNTERS_BINDING NFD_B_FIELD_COUNTERS
#include "counters.glsl"
#include "field.glsl"

#define LANES NFD_FIELD_LANES  // the local size: one subgroup
const uint SLOTS_0 = (4 * ENC4 + LANES - 1) / LANES;  // layer 0's weights: 4 * ENC4 columns
// The encoding's sines and cosines come in (frequency k, axis j) pairs q = 3k + j, each lane
// computing sin and cos of pairs q = s * LANES + lane.
const uint PAIRS = 3 * 4 * FREQ4;
const uint PAIR_SLOTS = (PAIRS + LANES - 1) / LANES;

// Rows per lane of each layer, and inputs per lane (the previous layer's rows per lane).
const uint ROWS_0 = (4 * OUT4_0 + LANES - 1) / LANES;
const uint ROWS_1 = (4 * OUT4_1 + LANES - 1) / LANES;
const uint ROWS_2 = (4 * OUT4_2 + LANES - 1) / LANES;
const uint ROWS_3 = (4 * OUT4_3 + LANES - 1) / LANES;
const uint ROWS_4 = (4 * OUT4_4 + LANES - 1) / LANES;
const uint ROWS_5 = (4 * OUT4_5 + LANES - 1) / LANES;
const uint ROWS_6 = (4 * OUT4_6 + LANES - 1) / LANES;
const uint ROWS_7 = (4 * OUT4_7 + LANES - 1) / LANES;

// OUTPUTS floats per point, point-major.
layout(std430, binding = NFD_B_FIELD_VALUES) writeonly buffer Values { float values[]; };

// Bias of row o of field_eval.comp's layout (IN4 vec4s a row, biases after the rows); zero for
// the padding rows this kernel's lanes add.
#define BIAS_AT(W, IN4, OUT4, o) ((o) < 4 * (OUT4) ? W.w[4 * (OUT4) * (IN4) + (o) / 4][(o) % 4] : 0.0)

// This lane's weights of layer K (ROWS rows of SLOTS * LANES inputs, zero past the layer's rows
// and columns) and biases, loaded a vec4 at a time into constant array indices (the loops are
// unrolled), so that the arrays stay out of memory. Loading them one float at a time made the
// pipeline 2.4x as long to create (lavapipe, width 32: 180 ms instead of 75 in every process,
// Mesa's disk cache or not), the same code once compiled.
#define LOAD_LAYER(K, W, IN4, OUT4, ROWS, SLOTS)                                             \
    float w##K[K < NUM_LAYERS ? ROWS * SLOTS * LANES : 1];                                  \
    float b##K[K < NUM_LAYERS ? ROWS : 1];                                                  \
    if (K < NUM_LAYERS) {                                                                   \
        [[unroll]] for (uint r = 0; r < ROWS; ++r) {                                        \
            uint o = r * LANES + lane;                                                      \
            b##K[r] = BIAS_AT(W, IN4, OUT4, o);                                             \
            [[unroll]] for (uint i4 = 0; i4 < SLOTS * LANES / 4; ++i4) {                    \
                vec4 v = o < 4 * (OUT4) && i4 < (IN4) ? W.w[o * (IN4) + i4] : vec4(0.0);    \
                [[unroll]] for (uint j = 0; j < 4; ++j) w##K[r * SLOTS * LANES + 4 * i4 + j] = v[j]; \
            }                                                                               \
        }                                                                                   \
    }

// Input c of a hidden layer: the previous layer's row c, from lane c % LANES's slot c / LANES.
#define HIDDEN_INPUT(SRC, c) subgroupShuffle(SRC[(c) / LANES], (c) % LANES)
// Input c of layer 0, in field_eval.comp's column order: (u, 0), then per block of 4 frequencies
// sin(f u_x), sin(f u_y), sin(f u_z), cos(f u_x), cos(f u_y), cos(f u_z), a frequency per lane
// of each vec4; the sines from the lane of their pair.
#define PAIR_OF(c) (3 * (4 * (((c) - 4) / 24) + ((c) - 4) % 4) + (((c) - 4) % 24 / 4) % 3)
#define ENCODED_INPUT(SRC, c)                                                               \
    ((c) < 3 ? u[c] : (c) == 3 ? 0.0                                                        \
     : subgroupShuffle(((c) - 4) % 24 < 12 ? sines[PAIR_OF(c) / LANES] : cosines[PAIR_OF(c) / LANES], \
                       PAIR_OF(c) % LANES))

// acc[r] += the dot products of row r's weight vec4s with the input vec4s, in input order (as
// field_eval.comp sums them); INPUT(SRC, c) gives input c.
#define ACCUMULATE(K, INPUT, SRC, ROWS, SLOTS, IN4)                                         \
    [[unroll]] for (uint i4 = 0; i4 < IN4; ++i4) {                                          \
        vec4 x = vec4(INPUT(SRC, 4 * i4), INPUT(SRC, 4 * i4 + 1), INPUT(SRC, 4 * i4 + 2),   \
                      INPUT(SRC, 4 * i4 + 3));                                              \
        [[unroll]] for (uint r = 0; r < ROWS; ++r) {                                        \
            uint c = r * SLOTS * LANES + 4 * i4;                                            \
            acc[r] += dot(vec4(w##K[c], w##K[c + 1], w##K[c + 2], w##K[c + 3]), x);         \
        }                                                                                   \
    }

// Layer K from SRC (IN4 input vec4s, SLOTS inputs a lane) into DST (ROWS outputs a lane):
// hidden layers apply sin(omega0 *), the last none.
#define LAYER(K, INPUT, SRC, DST, ROWS, SLOTS, IN4)                                         \
    float DST[K < NUM_LAYERS ? ROWS : 1];                                                   \
    if (K < NUM_LAYERS) {                                                                   \
        float acc[ROWS];                                                                    \
        [[unroll]] for (uint r = 0; r < ROWS; ++r) acc[r] = b##K[r];                        \
        ACCUMULATE(K, INPUT, SRC, ROWS, SLOTS, IN4)                                         \
        [[unroll]] for (uint r = 0; r < ROWS; ++r)                                          \
            DST[r] = K + 1 < NUM_LAYERS ? sin_reduced(OMEGA0 * acc[r]) : acc[r];           \
        if (K + 1 == NUM_LAYERS) y = DST[0];                                                \
    }

void main() {
    const uint lane = gl_SubgroupInvocationID;
    uint group = gl_WorkGroupID.x + gl_WorkGroupID.y * gl_NumWorkGroups.x;
    uint first = group * LANES * POINTS;
    uint count = counted_items(push.count, push.count_slot, push.first);
    if (first >= count) return;
    uint last = min(first + LANES * POINTS, count);

    LOAD_LAYER(0, layer0, ENC4, OUT4_0, ROWS_0, SLOTS_0)
    LOAD_LAYER(1, layer1, OUT4_0, OUT4_1, ROWS_1, ROWS_0)
    LOAD_LAYER(2, layer2, OUT4_1, OUT4_2, ROWS_2, ROWS_1)
    LOAD_LAYER(3, layer3, OUT4_2, OUT4_3, ROWS_3, ROWS_2)
    LOAD_LAYER(4, layer4, OUT4_3, OUT4_4, ROWS_4, ROWS_3)
    LOAD_LAYER(5, layer5, OUT4_4, OUT4_5, ROWS_5, ROWS_4)
    LOAD_LAYER(6, layer6, OUT4_5, OUT4_6, ROWS_6, ROWS_5)
    LOAD_LAYER(7, layer7, OUT4_6, OUT4_7, ROWS_7, ROWS_6)

    // This lane's sin/cos pairs: frequency and axis (past the last pair: never read).
    float pair_frequency[PAIR_SLOTS];
    uint pair_axis[PAIR_SLOTS];
    [[unroll]] for (uint s = 0; s < PAIR_SLOTS; ++s) {
        uint q = min(s * LANES + lane, PAIRS - 1);
        pair_frequency[s] = frequencies[q / 3 / 4][(q / 3) % 4];
        pair_axis[s] = q % 3;
    }

    vec3 own = vec3(0.0);
    for (uint p = first; p < last; ++p) {
        uint j = (p - first) % LANES;
        if (j == 0) {
            uint mine = min(p + lane, last - 1);
            own = vec3(points[3 * mine], points[3 * mine + 1], points[3 * mine + 2]);
        }
        vec3 u = subgroupShuffle(own, j);
        float sines[PAIR_SLOTS], cosines[PAIR_SLOTS];
        [[unroll]] for (uint s = 0; s < PAIR_SLOTS; ++s) {
            float coordinate = pair_axis[s] == 0 ? u.x : pair_axis[s] == 1 ? u.y : u.z;
            precise float a = pair_frequency[s] * coordinate;  // f32 product, as encode()
            vec2 sc = sincos_reduced(a);
            sines[s] = sc.x;
            cosines[s] = sc.y;
        }

        float y = 0.0;
        LAYER(0, ENCODED_INPUT, sines, a0, ROWS_0, SLOTS_0, ENC4)
        LAYER(1, HIDDEN_INPUT, a0, a1, ROWS_1, ROWS_0, OUT4_0)
        LAYER(2, HIDDEN_INPUT, a1, a2, ROWS_2, ROWS_1, OUT4_1)
        LAYER(3, HIDDEN_INPUT, a2, a3, ROWS_3, ROWS_2, OUT4_2)
        LAYER(4, HIDDEN_INPUT, a3, a4, ROWS_4, ROWS_3, OUT4_3)
        LAYER(5, HIDDEN_INPUT, a4, a5, ROWS_5, ROWS_4, OUT4_4)
        LAYER(6, HIDDEN_INPUT, a5, a6, ROWS_6, ROWS_5, OUT4_5)
        LAYER(7, HIDDEN_INPUT, a6, a7, ROWS_7, ROWS_6, OUT4_6)
        // The output layer's row `lane` is output `lane` (row r = 0 of each lane).
        if (lane < OUTPUTS) values[(push.first + p) * OUTPUTS + lane] = activate_output(y);
    }
}
