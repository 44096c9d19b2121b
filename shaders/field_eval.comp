// Evaluates the neural field (FORMAT.md, "Evaluation") at a list of unit-frame points.
//
// Shaped for CPU Vulkan implementations (lavapipe) as much as for GPUs. llvmpipe runs 8
// invocations as the lanes of one SIMD register; uniform-block loads at a constant offset from a
// uniform base are one scalar load and a broadcast, while per-invocation arrays indexed by a loop
// variable and storage-buffer loads become 8-lane gathers. So each layer loops over its outputs
// (uniform index) with the loop over its inputs unrolled: inputs are read at constant indices,
// weights at constant offsets from the row, and only one store per output is indexed. Each
// invocation carries POINTS points so that every weight load feeds POINTS multiply-adds. The
// unrolled body is in_features * POINTS multiply-adds: compiling stays well under a second, unlike
// unrolling whole layers (tens of seconds on llvmpipe).
//
// Network sizes are specialization constants. Weight layout (gpu_decode.cpp): per layer, rows of
// in_features weights then the bias, each row padded to whole vec4s, in one uniform block per layer
// (WEIGHTS_IN_STORAGE_BUFFER: storage buffers, for layers beyond maxUniformBufferRange).
#version 450
#extension GL_GOOGLE_include_directive : require
#extension GL_EXT_control_flow_attributes : require
#include "common.glsl"

layout(constant_id = 0) const uint NUM_FREQUENCIES = 16;
layout(constant_id = 1) const uint NUM_LAYERS = 3;
layout(constant_id = 2) const uint OUT_0 = 32;       // out_features per layer
layout(constant_id = 3) const uint OUT_1 = 32;
layout(constant_id = 4) const uint OUT_2 = 1;
layout(constant_id = 5) const uint OUT_3 = 1;
layout(constant_id = 6) const uint OUT_4 = 1;
layout(constant_id = 7) const uint OUT_5 = 1;
layout(constant_id = 8) const uint OUT_6 = 1;
layout(constant_id = 9) const uint OUT_7 = 1;
layout(constant_id = 10) const float OMEGA0 = 30.0;
layout(constant_id = 11) const uint OUTPUT_ACTIVATION = 0;  // 0 identity, 1 abs, 2 sigmoid
layout(constant_id = 12) const uint MAX_WIDTH = 99;  // widest layer input or output
layout(constant_id = 13) const uint POINTS = 8;      // points per invocation
layout(local_size_x_id = 14) in;
layout(constant_id = 14) const uint LOCAL_SIZE = 32;
// Evaluate point i at the i % 6-th central-difference sample around point i / 6 (+x, -x, +y, -y,
// +z, -z by push.normal_step) instead of at point i: vertex normals need no sample buffer.
layout(constant_id = 15) const bool CENTRAL_DIFFERENCES = false;

const uint IN_0 = 3 + 6 * NUM_FREQUENCIES;

layout(std430, binding = 0) readonly buffer Points { float points[]; };  // xyz per point
layout(std430, binding = 1) writeonly buffer Values { float values[]; };
layout(std140, binding = 2) uniform Frequencies { vec4 frequencies[6]; };  // 24 = MAX_FREQUENCIES

#ifdef WEIGHTS_IN_STORAGE_BUFFER
#define WEIGHT_BLOCK(B, NAME) layout(std430, binding = B) readonly buffer NAME##Block { vec4 w[]; } NAME;
#else
// 4096 vec4s = 65536 bytes, the largest range the host binds to one uniform block.
#define WEIGHT_BLOCK(B, NAME) layout(std140, binding = B) uniform NAME##Block { vec4 w[4096]; } NAME;
#endif
WEIGHT_BLOCK(3, layer0)
WEIGHT_BLOCK(4, layer1)
WEIGHT_BLOCK(5, layer2)
WEIGHT_BLOCK(6, layer3)
WEIGHT_BLOCK(7, layer4)
WEIGHT_BLOCK(8, layer5)
WEIGHT_BLOCK(9, layer6)
WEIGHT_BLOCK(10, layer7)

layout(push_constant) uniform Push { uint count; float normal_step; } push;

float ping[POINTS][MAX_WIDTH];
float pong[POINTS][MAX_WIDTH];

float activate_output(float y) {
    if (OUTPUT_ACTIVATION == 1) return abs(y);
    if (OUTPUT_ACTIVATION == 2) return 1.0 / (1.0 + exp(-y));
    return y;
}

// Layer K: DST[p][o] = act(sum_i W[o][i] SRC[p][i] + b[o]); the sum in input order, the bias
// last, as evaluate_cpu does. Hidden layers apply sin(omega0 * .), the last none.
#define LAYER(K, IN, OUT, W, SRC, DST)                                                      \
    if (K < NUM_LAYERS) {                                                                   \
        const uint ROW4 = (IN + 4) / 4; /* vec4s per row: IN weights and the bias */        \
        [[unroll]] for (uint o = 0; o < OUT; ++o) {                                    \
            uint row = o * ROW4;                                                            \
            float acc[POINTS];                                                              \
            [[unroll]] for (uint p = 0; p < POINTS; ++p) acc[p] = 0.0;                      \
            [[unroll]] for (uint i = 0; i < IN; ++i) {                                      \
                float w = W.w[row + i / 4][i % 4];                                          \
                [[unroll]] for (uint p = 0; p < POINTS; ++p) acc[p] += w * SRC[p][i];       \
            }                                                                               \
            float b = W.w[row + IN / 4][IN % 4];                                            \
            [[unroll]] for (uint p = 0; p < POINTS; ++p)                                    \
                DST[p][o] = K + 1 < NUM_LAYERS ? sin_reduced(OMEGA0 * (acc[p] + b)) : acc[p] + b; \
        }                                                                                   \
    }

void main() {
    uint first = global_invocation_index(LOCAL_SIZE) * POINTS;
    if (first >= push.count) return;

    // Positional encoding into ping; points past the end repeat the last one (results dropped).
    [[unroll]] for (uint p = 0; p < POINTS; ++p) {
        uint i = min(first + p, push.count - 1);
        uint j = CENTRAL_DIFFERENCES ? i / 6 : i;
        vec3 u = vec3(points[3 * j], points[3 * j + 1], points[3 * j + 2]);
        if (CENTRAL_DIFFERENCES) {
            uint axis = (i % 6) / 2;
            precise float moved = u[axis] + ((i & 1) == 0 ? push.normal_step : -push.normal_step);
            u[axis] = moved;
        }
        ping[p][0] = u.x;
        ping[p][1] = u.y;
        ping[p][2] = u.z;
        [[unroll]] for (uint k = 0; k < NUM_FREQUENCIES; ++k) {
            float f = frequencies[k / 4][k % 4];
            // The products are rounded to f32 before the reduction, as FORMAT.md specifies.
            precise vec3 a = f * u;
            vec2 x = sincos_reduced(a.x), y = sincos_reduced(a.y), z = sincos_reduced(a.z);
            ping[p][3 + 6 * k] = x.x;
            ping[p][4 + 6 * k] = y.x;
            ping[p][5 + 6 * k] = z.x;
            ping[p][6 + 6 * k] = x.y;
            ping[p][7 + 6 * k] = y.y;
            ping[p][8 + 6 * k] = z.y;
        }
    }

    LAYER(0, IN_0, OUT_0, layer0, ping, pong)
    LAYER(1, OUT_0, OUT_1, layer1, pong, ping)
    LAYER(2, OUT_1, OUT_2, layer2, ping, pong)
    LAYER(3, OUT_2, OUT_3, layer3, pong, ping)
    LAYER(4, OUT_3, OUT_4, layer4, ping, pong)
    LAYER(5, OUT_4, OUT_5, layer5, pong, ping)
    LAYER(6, OUT_5, OUT_6, layer6, ping, pong)
    LAYER(7, OUT_6, OUT_7, layer7, pong, ping)

    // The output layer K = NUM_LAYERS - 1 wrote pong when K is even, ping when odd.
    for (uint p = 0; p < POINTS && first + p < push.count; ++p) {
        float y = (NUM_LAYERS & 1) == 1 ? pong[p][0] : ping[p][0];
        values[first + p] = activate_output(y);
    }
}
