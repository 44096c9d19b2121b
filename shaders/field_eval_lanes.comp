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
//
// Defining WITH_GRADIENT gives the value + gradient variant (field_eval.comp's WITH_GRADIENT, a
// network with one output), in reverse mode: the forward pass is the value kernel's (the same
// value bits) and keeps each hidden unit's slope omega0 cos(omega0 z); the backward pass is the
// same shape run on the transposed weights. Each lane also holds the columns r * LANES + lane of
// every layer's weights (loaded once per workgroup), so d(output)/d(input c) is a row of the
// transposed layer, its inputs (the layer's output derivatives) shuffled from the lanes that own
// them, and it lands on the lane that owns unit c of the layer below, with its slope. At layer 0
// a lane's columns are the sine and cosine of its own (frequency, axis) pairs and, on lanes 0-2,
// the coordinate u itself, so each lane finishes its pairs' chain rule with its own sines and
// cosines; the three axes are then summed over the lanes. The gradient's sums run in another
// order than field_eval.comp's: the gradient agrees with it to rounding, not bit for bit.
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

// OUTPUTS floats per point, point-major; with WITH_GRADIENT (value, gradient) as 4 floats.
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

#ifdef WITH_GRADIENT
// This lane's columns of layer K as rows of its transposed weights (COLS slots of ROWS * LANES
// rows of K), from the transposed block that field.cpp appends to the layer's block (OUT4 vec4s
// a column; its slot s is column s * LANES + lane; layer 0's slots: field.cpp,
// transposed_source_column), a vec4 at a time as LOAD_LAYER.
#define LOAD_TRANSPOSED(K, W, IN4, OUT4, ROWS, COLS)                                         \
    float t##K[K < NUM_LAYERS ? COLS * ROWS * LANES : 1];                                   \
    if (K < NUM_LAYERS) {                                                                   \
        [[unroll]] for (uint s = 0; s < COLS; ++s) {                                        \
            uint column = (OUT4) * (4 * (IN4) + 1) + (s * LANES + lane) * (OUT4);          \
            [[unroll]] for (uint o4 = 0; o4 < ROWS * LANES / 4; ++o4) {                     \
                vec4 v = o4 < (OUT4) ? W.w[column + o4] : vec4(0.0);                        \
                [[unroll]] for (uint j = 0; j < 4; ++j) t##K[(s * ROWS * LANES) + 4 * o4 + j] = v[j]; \
            }                                                                               \
        }                                                                                   \
    }
// Layer 0's slots: per pair slot s the sine's and the cosine's column of pair s * LANES + lane,
// then the coordinate's column (lanes 0-2).
const uint ENCODED_COLS = 2 * PAIR_SLOTS + 1;
#endif

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

// acc[r] += the dot products of row r's weight vec4s (in WEIGHTS, SLOTS * LANES a row) with the
// input vec4s, in input order (as field_eval.comp sums them); INPUT(SRC, c) gives input c.
#define ACCUMULATE(WEIGHTS, INPUT, SRC, ROWS, SLOTS, IN4)                                   \
    [[unroll]] for (uint i4 = 0; i4 < IN4; ++i4) {                                          \
        vec4 x = vec4(INPUT(SRC, 4 * i4), INPUT(SRC, 4 * i4 + 1), INPUT(SRC, 4 * i4 + 2),   \
                      INPUT(SRC, 4 * i4 + 3));                                              \
        [[unroll]] for (uint r = 0; r < ROWS; ++r) {                                        \
            uint c = r * SLOTS * LANES + 4 * i4;                                            \
            acc[r] += dot(vec4(WEIGHTS[c], WEIGHTS[c + 1], WEIGHTS[c + 2], WEIGHTS[c + 3]), x); \
        }                                                                                   \
    }

// Layer K from SRC (IN4 input vec4s, SLOTS inputs a lane) into DST (ROWS outputs a lane):
// hidden layers apply sin(omega0 *), the last none. The gradient variant keeps each hidden
// unit's slope omega0 cos(omega0 z) in DST_slope, from the same sincos_reduced (sin_reduced is
// its sine: the same value bits).
#ifdef WITH_GRADIENT
#define ACTIVATE(DST, r, z)                                                                 \
    {                                                                                       \
        vec2 sc = sincos_reduced(OMEGA0 * z);                                               \
        DST[r] = sc.x;                                                                      \
        DST##_slope[r] = OMEGA0 * sc.y;                                                     \
    }
#define DECLARE_SLOPE(DST, n) float DST##_slope[n];
#else
#define ACTIVATE(DST, r, z) DST[r] = sin_reduced(OMEGA0 * z);
#define DECLARE_SLOPE(DST, n)
#endif
#define LAYER(K, INPUT, SRC, DST, ROWS, SLOTS, IN4)                                         \
    float DST[K < NUM_LAYERS ? ROWS : 1];                                                   \
    DECLARE_SLOPE(DST, K < NUM_LAYERS ? ROWS : 1)                                           \
    if (K < NUM_LAYERS) {                                                                   \
        float acc[ROWS];                                                                    \
        [[unroll]] for (uint r = 0; r < ROWS; ++r) acc[r] = b##K[r];                        \
        ACCUMULATE(w##K, INPUT, SRC, ROWS, SLOTS, IN4)                                      \
        [[unroll]] for (uint r = 0; r < ROWS; ++r) {                                        \
            if (K + 1 < NUM_LAYERS) ACTIVATE(DST, r, acc[r]) else DST[r] = acc[r];          \
        }                                                                                   \
        if (K + 1 == NUM_LAYERS) y = DST[0];                                                \
    }

#ifdef WITH_GRADIENT
// d(output)/d(z) of the output layer's rows this lane owns: the output's own derivative on row 0
// (lane 0's first slot), zero on the padding rows.
#define OUTPUT_DERIVATIVE(DST, ROWS)                                                        \
    [[unroll]] for (uint r = 0; r < ROWS; ++r) DST[r] = r == 0 && lane == 0 ? d_output : 0.0;
// Backward through layer K > 0: G holds d(output)/d(z_K) (ROWS_K rows a lane; for the output
// layer, OUTPUT_DERIVATIVE), DST receives d(output)/d(z_{K-1}) = (W_K^T G) * slope_{K-1}, on the
// lanes and slots that own layer K - 1's units (COLS a lane).
#define BACK_LAYER(K, G, ROWS, OUT4, DST, COLS, SLOPE)                                      \
    float DST[COLS];                                                                        \
    if (K < NUM_LAYERS) {                                                                   \
        float g_in[ROWS];                                                                   \
        if (K + 1 == NUM_LAYERS) {                                                          \
            OUTPUT_DERIVATIVE(g_in, ROWS)                                                   \
        } else {                                                                            \
            [[unroll]] for (uint r = 0; r < ROWS; ++r) g_in[r] = G[r];                      \
        }                                                                                   \
        float acc[COLS];                                                                    \
        [[unroll]] for (uint r = 0; r < COLS; ++r) acc[r] = 0.0;                            \
        ACCUMULATE(t##K, HIDDEN_INPUT, g_in, COLS, ROWS, OUT4)                              \
        [[unroll]] for (uint r = 0; r < COLS; ++r) DST[r] = acc[r] * SLOPE[r];              \
    }
#endif

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
#ifdef WITH_GRADIENT
    LOAD_TRANSPOSED(0, layer0, ENC4, OUT4_0, ROWS_0, ENCODED_COLS)
    LOAD_TRANSPOSED(1, layer1, OUT4_0, OUT4_1, ROWS_1, ROWS_0)
    LOAD_TRANSPOSED(2, layer2, OUT4_1, OUT4_2, ROWS_2, ROWS_1)
    LOAD_TRANSPOSED(3, layer3, OUT4_2, OUT4_3, ROWS_3, ROWS_2)
    LOAD_TRANSPOSED(4, layer4, OUT4_3, OUT4_4, ROWS_4, ROWS_3)
    LOAD_TRANSPOSED(5, layer5, OUT4_4, OUT4_5, ROWS_5, ROWS_4)
    LOAD_TRANSPOSED(6, layer6, OUT4_5, OUT4_6, ROWS_6, ROWS_5)
    LOAD_TRANSPOSED(7, layer7, OUT4_6, OUT4_7, ROWS_7, ROWS_6)
#endif

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
#ifndef WITH_GRADIENT
        // The output layer's row `lane` is output `lane` (row r = 0 of each lane).
        if (lane < OUTPUTS)
            values[(push.first + p) * OUTPUTS + lane] = bounded(activate_output(y), u);
#else
        // Backward from the output (lane 0's y) to layer 0's outputs, then through layer 0 and
        // the encoding: sin(f u_a) has derivative f cos(f u_a), cos(f u_a) has -f sin(f u_a).
        float d_output = output_slope(y);
        float g7[ROWS_7];  // read by no layer: layer 7 can only be the output
        BACK_LAYER(7, g7, ROWS_7, OUT4_7, g6, ROWS_6, a6_slope)
        BACK_LAYER(6, g6, ROWS_6, OUT4_6, g5, ROWS_5, a5_slope)
        BACK_LAYER(5, g5, ROWS_5, OUT4_5, g4, ROWS_4, a4_slope)
        BACK_LAYER(4, g4, ROWS_4, OUT4_4, g3, ROWS_3, a3_slope)
        BACK_LAYER(3, g3, ROWS_3, OUT4_3, g2, ROWS_2, a2_slope)
        BACK_LAYER(2, g2, ROWS_2, OUT4_2, g1, ROWS_1, a1_slope)
        BACK_LAYER(1, g1, ROWS_1, OUT4_1, g0, ROWS_0, a0_slope)
        float g_in[ROWS_0];
        if (NUM_LAYERS == 1) {
            OUTPUT_DERIVATIVE(g_in, ROWS_0)
        } else {
            [[unroll]] for (uint r = 0; r < ROWS_0; ++r) g_in[r] = g0[r];
        }
        float acc[ENCODED_COLS];
        [[unroll]] for (uint m = 0; m < ENCODED_COLS; ++m) acc[m] = 0.0;
        ACCUMULATE(t0, HIDDEN_INPUT, g_in, ENCODED_COLS, ROWS_0, OUT4_0)
        // The coordinate's column: u_lane on lanes 0-2 (zero weights on the others).
        vec3 partial = acc[2 * PAIR_SLOTS] * vec3(equal(uvec3(0, 1, 2), uvec3(lane)));
        [[unroll]] for (uint s = 0; s < PAIR_SLOTS; ++s) {
            float d = pair_frequency[s] * (acc[2 * s] * cosines[s] - acc[2 * s + 1] * sines[s]);
            partial += d * vec3(equal(uvec3(0, 1, 2), uvec3(pair_axis[s])));
        }
        vec3 gradient = vec3(0.0);
        [[unroll]] for (uint l = 0; l < LANES; ++l) gradient += subgroupShuffle(partial, l);
        if (lane == 0) {
            uint o = 4 * (push.first + p);
            values[o] = bounded(activate_output(y), u);
            values[o + 1] = gradient.x;
            values[o + 2] = gradient.y;
            values[o + 3] = gradient.z;
        }
#endif
    }
}
