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
// Every layer's inputs are in field_eval.comp's column order (layer 0: the encoding as field.cpp
// uploads it), input c in slot c / LANES of lane c % LANES, and each output is summed as there:
// the bias, then per input vec4 the dot product of four weights with four inputs. So the values
// are field_eval.comp's bit for bit, as nfd_asset_evaluate_gradient's (the WITH_GRADIENT
// variant's forward pass) must equal nfd_asset_evaluate's.
#version 450
#extension GL_GOOGLE_include_directive : require
#extension GL_EXT_control_flow_attributes : require
#extension GL_KHR_shader_subgroup_shuffle : require
#include "common.glsl"
#include "bindings.h"
#define COUNTERS_BINDING NFD_B_FIELD_COUNTERS
#include "counters.glsl"

layout(constant_id = 0) const uint FREQ4 = 4;        // frequency blocks of 4 (field_eval.comp)
layout(constant_id = 1) const uint NUM_LAYERS = 3;
layout(constant_id = 2) const uint OUT4_0 = 8;
layout(constant_id = 3) const uint OUT4_1 = 8;
layout(constant_id = 4) const uint OUT4_2 = 1;
layout(constant_id = 5) const uint OUT4_3 = 1;
layout(constant_id = 6) const uint OUT4_4 = 1;
layout(constant_id = 7) const uint OUT4_5 = 1;
layout(constant_id = 8) const uint OUT4_6 = 1;
layout(constant_id = 9) const uint OUT4_7 = 1;
layout(constant_id = 10) const float OMEGA0 = 30.0;
layout(constant_id = 11) const uint OUTPUT_ACTIVATION = 0;  // 0 identity, 1 abs, 2 sigmoid
layout(constant_id = 12) const uint MAX4 = 25;       // unused here (field_eval.comp's arrays)
layout(constant_id = 13) const uint OUTPUTS = 1;
layout(constant_id = 14) const uint POINTS = 32;     // points per invocation: LANES * POINTS a group
layout(local_size_x_id = NFD_FIELD_LOCAL_SIZE_ID) in;  // LANES: one subgroup

#define LANES NFD_FIELD_LANES
const uint ENC4 = 1 + 6 * FREQ4;
const uint SLOTS_0 = (ENC4 + 1) / 2;  // layer 0's inputs per lane: 4 * ENC4 columns, 8 a slot

// Rows per lane of each layer, and inputs per lane (the previous layer's rows per lane).
const uint ROWS_0 = (4 * OUT4_0 + LANES - 1) / LANES;
const uint ROWS_1 = (4 * OUT4_1 + LANES - 1) / LANES;
const uint ROWS_2 = (4 * OUT4_2 + LANES - 1) / LANES;
const uint ROWS_3 = (4 * OUT4_3 + LANES - 1) / LANES;
const uint ROWS_4 = (4 * OUT4_4 + LANES - 1) / LANES;
const uint ROWS_5 = (4 * OUT4_5 + LANES - 1) / LANES;
const uint ROWS_6 = (4 * OUT4_6 + LANES - 1) / LANES;
const uint ROWS_7 = (4 * OUT4_7 + LANES - 1) / LANES;

layout(std430, binding = NFD_B_FIELD_POINTS) readonly buffer Points { float points[]; };
layout(std430, binding = NFD_B_FIELD_VALUES) writeonly buffer Values { float values[]; };
layout(std140, binding = NFD_B_FIELD_FREQUENCIES) uniform Frequencies {
    vec4 frequencies[NFD_GPU_MAX_FREQUENCIES / 4];
};
#define WEIGHT_BLOCK(B, NAME) \
    layout(std140, binding = B) uniform NAME##Block { vec4 w[NFD_GPU_UNIFORM_VEC4S]; } NAME;
WEIGHT_BLOCK(NFD_B_FIELD_LAYER0 + 0, layer0)
WEIGHT_BLOCK(NFD_B_FIELD_LAYER0 + 1, layer1)
WEIGHT_BLOCK(NFD_B_FIELD_LAYER0 + 2, layer2)
WEIGHT_BLOCK(NFD_B_FIELD_LAYER0 + 3, layer3)
WEIGHT_BLOCK(NFD_B_FIELD_LAYER0 + 4, layer4)
WEIGHT_BLOCK(NFD_B_FIELD_LAYER0 + 5, layer5)
WEIGHT_BLOCK(NFD_B_FIELD_LAYER0 + 6, layer6)
WEIGHT_BLOCK(NFD_B_FIELD_LAYER0 + 7, layer7)

layout(push_constant) uniform Push { uint count; uint first; uint count_slot; } push;

float activate_output(float y) {
    if (OUTPUT_ACTIVATION == 1) return abs(y);
    if (OUTPUT_ACTIVATION == 2) return 1.0 / (1.0 + exp(-y));
    return y;
}

// Scalar weight (row o, input column c) of field_eval.comp's layout, IN4 vec4s a row; zero for
// the padding rows and columns this kernel's lanes add.
#define WEIGHT_AT(W, IN4, OUT4, o, c) \
    ((o) < 4 * (OUT4) && (c) < 4 * (IN4) ? W.w[(o) * (IN4) + (c) / 4][(c) % 4] : 0.0)
#define BIAS_AT(W, IN4, OUT4, o) ((o) < 4 * (OUT4) ? W.w[4 * (OUT4) * (IN4) + (o) / 4][(o) % 4] : 0.0)

// This lane's weights of layer K (ROWS rows of SLOTS * LANES inputs) and biases, loaded at
// constant array indices (the loops are unrolled), so that the arrays stay out of memory.
#define LOAD_LAYER(K, W, IN4, OUT4, ROWS, SLOTS)                                             \
    float w##K[K < NUM_LAYERS ? ROWS * SLOTS * LANES : 1];                                  \
    float b##K[K < NUM_LAYERS ? ROWS : 1];                                                  \
    if (K < NUM_LAYERS) {                                                                   \
        [[unroll]] for (uint r = 0; r < ROWS; ++r) {                                        \
            uint o = r * LANES + lane;                                                      \
            b##K[r] = BIAS_AT(W, IN4, OUT4, o);                                             \
            [[unroll]] for (uint i = 0; i < SLOTS * LANES; ++i)                             \
                w##K[r * SLOTS * LANES + i] = WEIGHT_AT(W, IN4, OUT4, o, i);                \
        }                                                                                   \
    }

// acc[r] += the dot products of row r's weight vec4s with the input vec4s, in input order; input
// c = s * LANES + l is shuffled from lane l's slot s of SRC.
#define ACCUMULATE(K, SRC, ROWS, SLOTS, IN4)                                                \
    [[unroll]] for (uint i4 = 0; i4 < IN4; ++i4) {                                          \
        uint s = i4 / 2, l = 4 * (i4 % 2);                                                  \
        vec4 x = vec4(subgroupShuffle(SRC[s], l), subgroupShuffle(SRC[s], l + 1),           \
                      subgroupShuffle(SRC[s], l + 2), subgroupShuffle(SRC[s], l + 3));      \
        [[unroll]] for (uint r = 0; r < ROWS; ++r) {                                        \
            uint c = r * SLOTS * LANES + 4 * i4;                                            \
            acc[r] += dot(vec4(w##K[c], w##K[c + 1], w##K[c + 2], w##K[c + 3]), x);         \
        }                                                                                   \
    }

// Layer K from SRC (IN4 input vec4s, SLOTS inputs a lane) into DST (ROWS outputs a lane):
// hidden layers apply sin(omega0 *), the last none.
#define LAYER(K, SRC, DST, ROWS, SLOTS, IN4)                                                \
    float DST[K < NUM_LAYERS ? ROWS : 1];                                                   \
    if (K < NUM_LAYERS) {                                                                   \
        float acc[ROWS];                                                                    \
        [[unroll]] for (uint r = 0; r < ROWS; ++r) acc[r] = b##K[r];                        \
        ACCUMULATE(K, SRC, ROWS, SLOTS, IN4)                                                \
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

    // The encoding's columns this lane computes (field_eval.comp's order): 0 u_axis, 1 sin and
    // 2 cos of frequency * u_axis, 3 zero (padding).
    float column_frequency[SLOTS_0];
    uint column_axis[SLOTS_0], column_kind[SLOTS_0];
    [[unroll]] for (uint s = 0; s < SLOTS_0; ++s) {
        uint c = s * LANES + lane;
        uint e = max(c, 4u) - 4;  // past (u, 0): per block of 4 frequencies, 6 vec4s
        uint g = (e % 24) / 4;    // sin x, y, z, cos x, y, z
        column_frequency[s] = c < 4 ? 0.0 : frequencies[min(e / 24, FREQ4 - 1)][e % 4];
        column_axis[s] = c < 3 ? c : g % 3;
        column_kind[s] = c < 3 ? 0 : c < 4 || c >= 4 * ENC4 ? 3 : g < 3 ? 1 : 2;
    }

    vec3 own = vec3(0.0);
    for (uint p = first; p < last; ++p) {
        uint j = (p - first) % LANES;
        if (j == 0) {
            uint mine = min(p + lane, last - 1);
            own = vec3(points[3 * mine], points[3 * mine + 1], points[3 * mine + 2]);
        }
        vec3 u = subgroupShuffle(own, j);
        float h[SLOTS_0];
        [[unroll]] for (uint s = 0; s < SLOTS_0; ++s) {
            float coordinate = column_axis[s] == 0 ? u.x : column_axis[s] == 1 ? u.y : u.z;
            precise float a = column_frequency[s] * coordinate;  // f32 product, as encode()
            vec2 sc = sincos_reduced(a);
            uint kind = column_kind[s];
            h[s] = kind == 0 ? coordinate : kind == 1 ? sc.x : kind == 2 ? sc.y : 0.0;
        }

        float y = 0.0;
        LAYER(0, h, a0, ROWS_0, SLOTS_0, ENC4)
        LAYER(1, a0, a1, ROWS_1, ROWS_0, OUT4_0)
        LAYER(2, a1, a2, ROWS_2, ROWS_1, OUT4_1)
        LAYER(3, a2, a3, ROWS_3, ROWS_2, OUT4_2)
        LAYER(4, a3, a4, ROWS_4, ROWS_3, OUT4_3)
        LAYER(5, a4, a5, ROWS_5, ROWS_4, OUT4_4)
        LAYER(6, a5, a6, ROWS_6, ROWS_5, OUT4_5)
        LAYER(7, a6, a7, ROWS_7, ROWS_6, OUT4_6)
        // The output layer's row `lane` is output `lane` (row r = 0 of each lane).
        if (lane < OUTPUTS) values[(push.first + p) * OUTPUTS + lane] = activate_output(y);
    }
}
