// Evaluates the neural field (FORMAT.md, "Evaluation") at a list of unit-frame points.
//
// Shaped for CPU Vulkan implementations (lavapipe) as much as for GPUs. llvmpipe runs 8
// invocations as the lanes of SIMD registers, and every load whose address is not a compile-time
// constant (per-invocation arrays, and weights indexed by a loop counter) becomes an 8-lane
// gather. Each invocation therefore carries POINTS points, and each weight vec4 it loads feeds
// POINTS x 4 multiply-adds. Network sizes are specialization constants so loop bounds are
// constants, without unrolling whole layers. Measured on 2-core llvmpipe, width 32, 1M points,
// CPU time: this shape 0.9 s; outputs unrolled with inputs read by constant index 2.1 s (and a
// 25 s compile); activations in named variables with fully unrolled layers 3.3 s. Later tries
// (1M points, wall with about one core free; this shape 1.0 s): [[unroll]] on the input and point
// loops, 0.9 s after a 40 s compile; whole layers unrolled at 2 or 4 points per invocation, 6 s
// and 3 s after 45-67 s compiles; 4 or 16 points per invocation 1.3 s / 1.0 s; local size 8 or 64
// no change. A constant in place of the `ping`/`pong` reads (which also lets the compiler drop
// the encoding and layer 0) gives 0.3 s: the per-lane gathers at loop-counter indices dominate.
// So on such devices field_eval_lanes.comp, which has no gathers in its point loop and gives
// this kernel's value bits, evaluates the values and gradients of networks up to 48 wide (0.17 s
// for the same 1M values); this kernel keeps wider networks and storage-buffer layers.
//
// Weight layout (written by gpu_decode.cpp): per layer, rows of `in4` vec4s, the output padded to
// a multiple of 4 with zero rows, then the bias as out4 vec4s. Layer 0's columns are permuted to
// match the encoding below ([u, 0], then per block of 4 frequencies sin(f u_x), sin(f u_y),
// sin(f u_z), cos(f u_x), cos(f u_y), cos(f u_z)), with zero columns for padded frequencies.
// Defining WEIGHTS_IN_STORAGE_BUFFER gives the variant for layers larger than the device's
// maxUniformBufferRange.
//
// Defining WEIGHTS_IN_SHARED gives the shape for GPUs (field.cpp picks it on a device that is not
// a CPU implementation, when the weights fit the workgroup's shared memory): run with POINTS = 1,
// one point per invocation, the workgroup first copies every layer's block into shared memory
// (SHARED_VEC4 vec4s, the layers back to back), so the weight reads of the layers hit on-chip
// memory rather than the uniform path. The arithmetic is the value kernel's, in the same order: the
// same bits. Tested on lavapipe against the CPU twin (not measured on a GPU: none in this project's
// machines so far).
//
// Defining WITH_GRADIENT gives the value + gradient variant (network.h, evaluate_gradient_cpu) of
// a network with one output,
// in reverse mode: the forward pass is the value kernel's (the same rows, so the same value bit
// for bit) and also keeps each hidden unit's slope omega0 cos(omega0 z); the backward pass sends
// the output's derivative back through the transposed weights (each weight vec4 again feeding
// POINTS rows) and, at layer 0, through the encoding. Forward mode (four rows per point: value,
// d/dx, d/dy, d/dz) cost 4.3x a value on 2-core llvmpipe, width 32; reverse mode: see
// bench/RESULTS.md. The output is (value, gradient) as one vec4 per point.
#version 450
#extension GL_GOOGLE_include_directive : require
#extension GL_EXT_control_flow_attributes : require
#include "common.glsl"
#include "bindings.h"
#define COUNTERS_BINDING NFD_B_FIELD_COUNTERS
#include "counters.glsl"
#include "field.glsl"

layout(constant_id = 16) const uint SHARED_VEC4 = 1; // WEIGHTS_IN_SHARED: every layer's vec4s

#ifdef WITH_GRADIENT
layout(std430, binding = NFD_B_FIELD_VALUES) writeonly buffer Values { vec4 values[]; };
#else
// OUTPUTS floats per point (a colour's RGB), point-major.
layout(std430, binding = NFD_B_FIELD_VALUES) writeonly buffer Values { float values[]; };
#endif
#ifdef WEIGHTS_IN_SHARED
// Layer K's block (OUT4 rows of 4 * IN4 vec4s, then OUT4 bias vec4s) starts at layerK_BASE.
shared vec4 weight_cache[SHARED_VEC4];
const uint layer0_BASE = 0;
const uint layer1_BASE = layer0_BASE + OUT4_0 * (4 * ENC4 + 1);
const uint layer2_BASE = layer1_BASE + OUT4_1 * (4 * OUT4_0 + 1);
const uint layer3_BASE = layer2_BASE + OUT4_2 * (4 * OUT4_1 + 1);
const uint layer4_BASE = layer3_BASE + OUT4_3 * (4 * OUT4_2 + 1);
const uint layer5_BASE = layer4_BASE + OUT4_4 * (4 * OUT4_3 + 1);
const uint layer6_BASE = layer5_BASE + OUT4_5 * (4 * OUT4_4 + 1);
const uint layer7_BASE = layer6_BASE + OUT4_6 * (4 * OUT4_5 + 1);
#define WEIGHT(W, i) weight_cache[W##_BASE + (i)]
#define COPY_LAYER(K, IN4, OUT4, W)                                                         \
    if (K < NUM_LAYERS)                                                                     \
        for (uint j = gl_LocalInvocationIndex; j < OUT4 * (4 * IN4 + 1); j += gl_WorkGroupSize.x) \
            weight_cache[W##_BASE + j] = W.w[j];
#else
#define WEIGHT(W, i) W.w[i]
#endif

vec4 ping[POINTS * MAX4];
vec4 pong[POINTS * MAX4];
#ifdef WITH_GRADIENT
// slope[(K * POINTS + p) * MAX4 + o4]: omega0 cos(omega0 z) of hidden layer K's outputs.
vec4 slope[(NUM_LAYERS - 1) * POINTS * MAX4];
#endif

// Hidden activation of point p into DST at output vec4 o4: sin(omega0 z), and in the gradient
// variant also its slope omega0 cos(omega0 z), from the same sincos_reduced.
#ifdef WITH_GRADIENT
#define ACTIVATE(K, DST, p, o4, acc)                                                        \
    {                                                                                       \
        vec4 s, ds;                                                                         \
        [[unroll]] for (uint j = 0; j < 4; ++j) {                                           \
            vec2 sc = sincos_reduced(OMEGA0 * acc[p][j]);                                   \
            s[j] = sc.x;                                                                    \
            ds[j] = OMEGA0 * sc.y;                                                          \
        }                                                                                   \
        DST[p * MAX4 + o4] = s;                                                             \
        slope[(K * POINTS + p) * MAX4 + o4] = ds;                                           \
    }
#else
#define ACTIVATE(K, DST, p, o4, acc) DST[p * MAX4 + o4] = sin_reduced(OMEGA0 * acc[p]);
#endif

// One linear layer over the POINTS rows, four outputs at a time so that each weight vec4 feeds
// POINTS dot products. Hidden layers apply sin(omega0 * .) (ACTIVATE), the last none.
#define LAYER(K, IN4, OUT4, W, SRC, DST)                                                    \
    if (K < NUM_LAYERS) {                                                                   \
        for (uint o4 = 0; o4 < OUT4; ++o4) {                                                \
            vec4 acc[POINTS];                                                               \
            vec4 bias = WEIGHT(W, OUT4 * 4 * IN4 + o4);                                           \
            for (uint p = 0; p < POINTS; ++p) acc[p] = bias;                                \
            uint row = o4 * 4 * IN4;                                                        \
            for (uint i = 0; i < IN4; ++i) {                                                \
                vec4 w0 = WEIGHT(W, row + i), w1 = WEIGHT(W, row + i + IN4);                            \
                vec4 w2 = WEIGHT(W, row + i + 2 * IN4), w3 = WEIGHT(W, row + i + 3 * IN4);              \
                [[unroll]] for (uint p = 0; p < POINTS; ++p) {                              \
                    vec4 x = SRC[p * MAX4 + i];                                             \
                    acc[p] += vec4(dot(w0, x), dot(w1, x), dot(w2, x), dot(w3, x));         \
                }                                                                           \
            }                                                                               \
            if (K + 1 < NUM_LAYERS) {                                                       \
                [[unroll]] for (uint p = 0; p < POINTS; ++p) ACTIVATE(K, DST, p, o4, acc)   \
            } else {                                                                        \
                for (uint p = 0; p < POINTS; ++p) DST[p * MAX4 + o4] = acc[p];              \
            }                                                                               \
        }                                                                                   \
    }

#ifdef WITH_GRADIENT
// d(output) / d(input vec4 i) of layer W for point p, given d(output) / d(layer outputs) in SRC:
// column block i of the transposed weights. Padded outputs have zero weights, so their lanes of
// SRC do not matter.
#define BACK_COLUMN(OUT4, IN4, W, SRC, i, acc)                                              \
    {                                                                                       \
        for (uint p = 0; p < POINTS; ++p) acc[p] = vec4(0.0);                               \
        for (uint o4 = 0; o4 < OUT4; ++o4) {                                                \
            uint row = o4 * 4 * IN4 + i;                                                    \
            vec4 w0 = WEIGHT(W, row), w1 = WEIGHT(W, row + IN4);                                        \
            vec4 w2 = WEIGHT(W, row + 2 * IN4), w3 = WEIGHT(W, row + 3 * IN4);                          \
            [[unroll]] for (uint p = 0; p < POINTS; ++p) {                                  \
                vec4 d = SRC[p * MAX4 + o4];                                                \
                acc[p] += d.x * w0 + d.y * w1 + d.z * w2 + d.w * w3;                        \
            }                                                                               \
        }                                                                                   \
    }

// Backward through hidden layer K > 0 (inputs: the outputs of layer K - 1): SRC holds
// d(output) / d(z_K), DST receives d(output) / d(z_{K-1}) = (W_K^T SRC) * slope_{K-1}.
#define BACK_LAYER(K, IN4, OUT4, W, SRC, DST)                                               \
    if (K < NUM_LAYERS) {                                                                   \
        for (uint i = 0; i < IN4; ++i) {                                                    \
            vec4 acc[POINTS];                                                               \
            BACK_COLUMN(OUT4, IN4, W, SRC, i, acc)                                          \
            for (uint p = 0; p < POINTS; ++p)                                               \
                DST[p * MAX4 + i] = acc[p] * slope[((K - 1) * POINTS + p) * MAX4 + i];      \
        }                                                                                   \
    }
#endif

// sin and cos of the four frequencies of block b times one coordinate (columns 0 and 1). The
// products are rounded to f32 before the reduction, as FORMAT.md specifies.
mat2x4 encode(uint b, float coordinate) {
    precise vec4 a = frequencies[b] * coordinate;
    vec2 s0 = sincos_reduced(a.x), s1 = sincos_reduced(a.y);
    vec2 s2 = sincos_reduced(a.z), s3 = sincos_reduced(a.w);
    return mat2x4(vec4(s0.x, s1.x, s2.x, s3.x), vec4(s0.y, s1.y, s2.y, s3.y));
}

void main() {
#ifdef WEIGHTS_IN_SHARED
    // Before any invocation leaves: the barrier needs the whole workgroup.
    COPY_LAYER(0, ENC4, OUT4_0, layer0)
    COPY_LAYER(1, OUT4_0, OUT4_1, layer1)
    COPY_LAYER(2, OUT4_1, OUT4_2, layer2)
    COPY_LAYER(3, OUT4_2, OUT4_3, layer3)
    COPY_LAYER(4, OUT4_3, OUT4_4, layer4)
    COPY_LAYER(5, OUT4_4, OUT4_5, layer5)
    COPY_LAYER(6, OUT4_5, OUT4_6, layer6)
    COPY_LAYER(7, OUT4_6, OUT4_7, layer7)
    barrier();
#endif
    uint first = global_invocation_index(gl_WorkGroupSize.x) * POINTS;
    uint count = counted_items(push.count, push.count_slot, push.first);
    if (first >= count) return;

    // Positional encoding into ping; points past the end repeat the last one (results dropped).
    for (uint p = 0; p < POINTS; ++p) {
        uint i = min(first + p, count - 1);
        vec3 u = vec3(points[3 * i], points[3 * i + 1], points[3 * i + 2]);
        uint v = p * MAX4;
        ping[v] = vec4(u, 0.0);
        for (uint b = 0; b < FREQ4; ++b) {
            mat2x4 ex = encode(b, u.x), ey = encode(b, u.y), ez = encode(b, u.z);
            uint base = v + 1 + 6 * b;
            ping[base + 0] = ex[0];
            ping[base + 1] = ey[0];
            ping[base + 2] = ez[0];
            ping[base + 3] = ex[1];
            ping[base + 4] = ey[1];
            ping[base + 5] = ez[1];
        }
    }

    LAYER(0, ENC4, OUT4_0, layer0, ping, pong)
    LAYER(1, OUT4_0, OUT4_1, layer1, pong, ping)
    LAYER(2, OUT4_1, OUT4_2, layer2, ping, pong)
    LAYER(3, OUT4_2, OUT4_3, layer3, pong, ping)
    LAYER(4, OUT4_3, OUT4_4, layer4, ping, pong)
    LAYER(5, OUT4_4, OUT4_5, layer5, pong, ping)
    LAYER(6, OUT4_5, OUT4_6, layer6, ping, pong)
    LAYER(7, OUT4_6, OUT4_7, layer7, pong, ping)

    // The output layer K = NUM_LAYERS - 1 wrote pong when K is even, ping when odd.
#ifndef WITH_GRADIENT
    for (uint p = 0; p < POINTS && first + p < count; ++p) {
        vec4 y = (NUM_LAYERS & 1) == 1 ? pong[p * MAX4] : ping[p * MAX4];
        uint i = first + p;
        vec3 u = vec3(points[3 * i], points[3 * i + 1], points[3 * i + 2]);
        for (uint k = 0; k < OUTPUTS; ++k)
            values[(push.first + i) * OUTPUTS + k] = bounded(activate_output(y[k]), u);
    }
#else
    // Backward from the output (one unit in lane x of vec4 0) down to the inputs of layer 1; the
    // output's array holds y, and the derivative d activate / dy replaces it there.
    float y[POINTS];
    for (uint p = 0; p < POINTS; ++p) {
        y[p] = (NUM_LAYERS & 1) == 1 ? pong[p * MAX4].x : ping[p * MAX4].x;
        vec4 d = vec4(output_slope(y[p]), 0.0, 0.0, 0.0);
        if ((NUM_LAYERS & 1) == 1) pong[p * MAX4] = d; else ping[p * MAX4] = d;
    }
    BACK_LAYER(7, OUT4_6, OUT4_7, layer7, ping, pong)
    BACK_LAYER(6, OUT4_5, OUT4_6, layer6, pong, ping)
    BACK_LAYER(5, OUT4_4, OUT4_5, layer5, ping, pong)
    BACK_LAYER(4, OUT4_3, OUT4_4, layer4, pong, ping)
    BACK_LAYER(3, OUT4_2, OUT4_3, layer3, ping, pong)
    BACK_LAYER(2, OUT4_1, OUT4_2, layer2, pong, ping)
    BACK_LAYER(1, OUT4_0, OUT4_1, layer1, ping, pong)
    // Now pong holds d(output) / d(z_0) (BACK_LAYER(1) wrote it, or the output itself is layer
    // 0). Through layer 0 and the encoding: vec4 0 is (u, 0); per block b and axis a, sin(f u_a)
    // has derivative f cos(f u_a) and cos(f u_a) has -f sin(f u_a), along axis a only.
    vec3 gradient[POINTS];
    {
        vec4 acc[POINTS];
        BACK_COLUMN(OUT4_0, ENC4, layer0, pong, 0, acc)
        for (uint p = 0; p < POINTS; ++p) gradient[p] = acc[p].xyz;
    }
    for (uint b = 0; b < FREQ4; ++b) {
        vec4 f = frequencies[b];
        [[unroll]] for (uint a = 0; a < 3; ++a) {
            vec4 d_sin[POINTS], d_cos[POINTS];
            BACK_COLUMN(OUT4_0, ENC4, layer0, pong, 1 + 6 * b + a, d_sin)
            BACK_COLUMN(OUT4_0, ENC4, layer0, pong, 4 + 6 * b + a, d_cos)
            for (uint p = 0; p < POINTS; ++p) {
                uint i = min(first + p, count - 1);
                mat2x4 e = encode(b, points[3 * i + a]);
                gradient[p][a] += dot(d_sin[p], f * e[1]) - dot(d_cos[p], f * e[0]);
            }
        }
    }
    for (uint p = 0; p < POINTS && first + p < count; ++p) {
        uint i = first + p;
        vec3 u = vec3(points[3 * i], points[3 * i + 1], points[3 * i + 2]);
        values[push.first + i] = vec4(bounded(activate_output(y[p]), u), gradient[p]);
    }
#endif
}

