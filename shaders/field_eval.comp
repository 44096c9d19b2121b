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
//
// Weight layout (written by gpu_decode.cpp): per layer, rows of `in4` vec4s, the output padded to
// a multiple of 4 with zero rows, then the bias as out4 vec4s. Layer 0's columns are permuted to
// match the encoding below ([u, 0], then per block of 4 frequencies sin(f u_x), sin(f u_y),
// sin(f u_z), cos(f u_x), cos(f u_y), cos(f u_z)), with zero columns for padded frequencies.
// Defining WEIGHTS_IN_STORAGE_BUFFER gives the variant for layers larger than the device's
// maxUniformBufferRange.
//
// Defining WITH_GRADIENT gives the value + gradient variant (network.h, evaluate_gradient_cpu):
// forward mode, each point carries COMP = 4 rows of activations, the value and its derivatives
// along x, y, z. The derivative rows go through the same weight vec4s as the value row, so a
// weight load feeds POINTS x COMP rows; only the bias and the activation's chain rule
// (omega0 cos(omega0 z), from the same sincos_reduced as the value) tell them apart. The output
// is (value, gradient) as one vec4 per point.
#version 450
#extension GL_GOOGLE_include_directive : require
#extension GL_EXT_control_flow_attributes : require
#include "common.glsl"
#include "bindings.h"

layout(constant_id = 0) const uint FREQ4 = 4;        // frequency blocks of 4
layout(constant_id = 1) const uint NUM_LAYERS = 3;
layout(constant_id = 2) const uint OUT4_0 = 8;       // out_features / 4, rounded up, per layer
layout(constant_id = 3) const uint OUT4_1 = 8;
layout(constant_id = 4) const uint OUT4_2 = 1;
layout(constant_id = 5) const uint OUT4_3 = 1;
layout(constant_id = 6) const uint OUT4_4 = 1;
layout(constant_id = 7) const uint OUT4_5 = 1;
layout(constant_id = 8) const uint OUT4_6 = 1;
layout(constant_id = 9) const uint OUT4_7 = 1;
layout(constant_id = 10) const float OMEGA0 = 30.0;
layout(constant_id = 11) const uint OUTPUT_ACTIVATION = 0;  // 0 identity, 1 abs, 2 sigmoid
layout(constant_id = 12) const uint MAX4 = 25;       // widest layer input/output, in vec4s
layout(constant_id = 13) const uint POINTS = 8;      // points per invocation
layout(local_size_x_id = NFD_FIELD_LOCAL_SIZE_ID) in;

const uint ENC4 = 1 + 6 * FREQ4;
#ifdef WITH_GRADIENT
const uint COMP = 4;  // rows per point: value, d/dx, d/dy, d/dz
#else
const uint COMP = 1;
#endif
const uint ROWS = POINTS * COMP;  // row r is component r % COMP of point r / COMP

layout(std430, binding = NFD_B_FIELD_POINTS) readonly buffer Points { float points[]; };
#ifdef WITH_GRADIENT
layout(std430, binding = NFD_B_FIELD_VALUES) writeonly buffer Values { vec4 values[]; };
#else
layout(std430, binding = NFD_B_FIELD_VALUES) writeonly buffer Values { float values[]; };
#endif
layout(std140, binding = NFD_B_FIELD_FREQUENCIES) uniform Frequencies {
    vec4 frequencies[NFD_GPU_MAX_FREQUENCIES / 4];
};

#ifdef WEIGHTS_IN_STORAGE_BUFFER
#define WEIGHT_BLOCK(B, NAME) \
    layout(std430, binding = B) readonly buffer NAME##Block { vec4 w[]; } NAME;
#else
// 64 KiB, the largest range the host binds to one uniform block.
#define WEIGHT_BLOCK(B, NAME) \
    layout(std140, binding = B) uniform NAME##Block { vec4 w[NFD_GPU_UNIFORM_VEC4S]; } NAME;
#endif
WEIGHT_BLOCK(NFD_B_FIELD_LAYER0 + 0, layer0)
WEIGHT_BLOCK(NFD_B_FIELD_LAYER0 + 1, layer1)
WEIGHT_BLOCK(NFD_B_FIELD_LAYER0 + 2, layer2)
WEIGHT_BLOCK(NFD_B_FIELD_LAYER0 + 3, layer3)
WEIGHT_BLOCK(NFD_B_FIELD_LAYER0 + 4, layer4)
WEIGHT_BLOCK(NFD_B_FIELD_LAYER0 + 5, layer5)
WEIGHT_BLOCK(NFD_B_FIELD_LAYER0 + 6, layer6)
WEIGHT_BLOCK(NFD_B_FIELD_LAYER0 + 7, layer7)

// Point i of the input is result first + i: a long list is evaluated in chunks of points.
layout(push_constant) uniform Push { uint count; uint first; } push;

vec4 ping[ROWS * MAX4];
vec4 pong[ROWS * MAX4];

float activate_output(float y) {
    if (OUTPUT_ACTIVATION == 1) return abs(y);
    if (OUTPUT_ACTIVATION == 2) return 1.0 / (1.0 + exp(-y));
    return y;
}
float output_slope(float y) {  // d activate_output / dy; abs: sign(y) with sign(0) = +1
    if (OUTPUT_ACTIVATION == 1) return y >= 0.0 ? 1.0 : -1.0;
    if (OUTPUT_ACTIVATION == 2) {
        float s = 1.0 / (1.0 + exp(-y));
        return s * (1.0 - s);
    }
    return 1.0;
}

// Hidden activation of rows p * COMP .. p * COMP + COMP - 1 into DST at output vec4 o4:
// sin(omega0 z) for the value, omega0 cos(omega0 z) dz for the derivatives.
#ifdef WITH_GRADIENT
#define ACTIVATE(DST, p, o4, acc)                                                           \
    {                                                                                       \
        vec4 s, slope;                                                                      \
        [[unroll]] for (uint j = 0; j < 4; ++j) {                                           \
            vec2 sc = sincos_reduced(OMEGA0 * acc[p * COMP][j]);                            \
            s[j] = sc.x;                                                                    \
            slope[j] = OMEGA0 * sc.y;                                                       \
        }                                                                                   \
        DST[p * COMP * MAX4 + o4] = s;                                                      \
        [[unroll]] for (uint c = 1; c < COMP; ++c)                                          \
            DST[(p * COMP + c) * MAX4 + o4] = slope * acc[p * COMP + c];                    \
    }
#else
#define ACTIVATE(DST, p, o4, acc) DST[p * MAX4 + o4] = sin_reduced(OMEGA0 * acc[p]);
#endif

// One linear layer over all ROWS rows, four outputs at a time so that each weight vec4 feeds
// ROWS dot products. Hidden layers apply sin(omega0 * .) (ACTIVATE), the last none. The bias
// goes to value rows only. Layer 0's inputs each depend on one coordinate (vec4 0 = (u, 0) on all
// three), so of its derivative rows, row 1 + a needs only the 1 + 2 FREQ4 vec4s of axis a: vec4 0
// and per block b the sin and cos vec4s (1 + 6 b + a, 4 + 6 b + a); the others are zero and are
// neither written nor read, which cuts the gradient variant's work on the widest layer by 3x.
#define LAYER(K, IN4, OUT4, W, SRC, DST)                                                    \
    if (K < NUM_LAYERS) {                                                                   \
        const uint dense_stride = K == 0 ? COMP : 1;                                        \
        for (uint o4 = 0; o4 < OUT4; ++o4) {                                                \
            vec4 acc[ROWS];                                                                 \
            vec4 bias = W.w[OUT4 * 4 * IN4 + o4];                                           \
            for (uint r = 0; r < ROWS; ++r) acc[r] = r % COMP == 0 ? bias : vec4(0.0);      \
            uint row = o4 * 4 * IN4;                                                        \
            for (uint i = 0; i < IN4; ++i) {                                                \
                vec4 w0 = W.w[row + i], w1 = W.w[row + i + IN4];                            \
                vec4 w2 = W.w[row + i + 2 * IN4], w3 = W.w[row + i + 3 * IN4];              \
                [[unroll]] for (uint r = 0; r < ROWS; r += dense_stride) {                  \
                    vec4 x = SRC[r * MAX4 + i];                                             \
                    acc[r] += vec4(dot(w0, x), dot(w1, x), dot(w2, x), dot(w3, x));         \
                }                                                                           \
            }                                                                               \
            if (K == 0 && COMP > 1) {                                                       \
                [[unroll]] for (uint a = 0; a < 3; ++a) {                                   \
                    for (uint j = 0; j <= 2 * FREQ4; ++j) {                                 \
                        uint i = j == 0 ? 0 : 1 + 6 * ((j - 1) / 2) + 3 * ((j - 1) % 2) + a;\
                        vec4 w0 = W.w[row + i], w1 = W.w[row + i + IN4];                    \
                        vec4 w2 = W.w[row + i + 2 * IN4], w3 = W.w[row + i + 3 * IN4];      \
                        [[unroll]] for (uint p = 0; p < POINTS; ++p) {                      \
                            uint r = p * COMP + 1 + a;                                      \
                            vec4 x = SRC[r * MAX4 + i];                                     \
                            acc[r] += vec4(dot(w0, x), dot(w1, x), dot(w2, x), dot(w3, x)); \
                        }                                                                   \
                    }                                                                       \
                }                                                                           \
            }                                                                               \
            if (K + 1 < NUM_LAYERS) {                                                       \
                [[unroll]] for (uint p = 0; p < POINTS; ++p) ACTIVATE(DST, p, o4, acc)      \
            } else {                                                                        \
                for (uint r = 0; r < ROWS; ++r) DST[r * MAX4 + o4] = acc[r];                \
            }                                                                               \
        }                                                                                   \
    }

void main() {
    uint first = global_invocation_index(gl_WorkGroupSize.x) * POINTS;
    if (first >= push.count) return;

    // Positional encoding into ping; points past the end repeat the last one (results dropped).
    for (uint p = 0; p < POINTS; ++p) {
        uint i = min(first + p, push.count - 1);
        vec3 u = vec3(points[3 * i], points[3 * i + 1], points[3 * i + 2]);
        uint v = p * COMP * MAX4;  // the value row of point p
        ping[v] = vec4(u, 0.0);
#ifdef WITH_GRADIENT
        ping[v + MAX4] = vec4(1.0, 0.0, 0.0, 0.0);  // du / du_x
        ping[v + 2 * MAX4] = vec4(0.0, 1.0, 0.0, 0.0);
        ping[v + 3 * MAX4] = vec4(0.0, 0.0, 1.0, 0.0);
#endif
        for (uint b = 0; b < FREQ4; ++b) {
            vec4 f = frequencies[b];
            // The products are rounded to f32 before the reduction, as FORMAT.md specifies.
            precise vec4 ax = f * u.x, ay = f * u.y, az = f * u.z;
            vec2 sx0 = sincos_reduced(ax.x), sx1 = sincos_reduced(ax.y);
            vec2 sx2 = sincos_reduced(ax.z), sx3 = sincos_reduced(ax.w);
            vec2 sy0 = sincos_reduced(ay.x), sy1 = sincos_reduced(ay.y);
            vec2 sy2 = sincos_reduced(ay.z), sy3 = sincos_reduced(ay.w);
            vec2 sz0 = sincos_reduced(az.x), sz1 = sincos_reduced(az.y);
            vec2 sz2 = sincos_reduced(az.z), sz3 = sincos_reduced(az.w);
            uint base = 1 + 6 * b;
            vec4 sin_x = vec4(sx0.x, sx1.x, sx2.x, sx3.x), cos_x = vec4(sx0.y, sx1.y, sx2.y, sx3.y);
            vec4 sin_y = vec4(sy0.x, sy1.x, sy2.x, sy3.x), cos_y = vec4(sy0.y, sy1.y, sy2.y, sy3.y);
            vec4 sin_z = vec4(sz0.x, sz1.x, sz2.x, sz3.x), cos_z = vec4(sz0.y, sz1.y, sz2.y, sz3.y);
            ping[v + base + 0] = sin_x;
            ping[v + base + 1] = sin_y;
            ping[v + base + 2] = sin_z;
            ping[v + base + 3] = cos_x;
            ping[v + base + 4] = cos_y;
            ping[v + base + 5] = cos_z;
#ifdef WITH_GRADIENT
            // d sin(f u_a) = f cos(f u_a) du_a, d cos(f u_a) = -f sin(f u_a) du_a, in row 1 + a
            // only (LAYER skips the other two).
            uint dx = v + MAX4 + base, dy = dx + MAX4, dz = dy + MAX4;
            ping[dx + 0] = f * cos_x;
            ping[dx + 3] = -f * sin_x;
            ping[dy + 1] = f * cos_y;
            ping[dy + 4] = -f * sin_y;
            ping[dz + 2] = f * cos_z;
            ping[dz + 5] = -f * sin_z;
#endif
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
    for (uint p = 0; p < POINTS && first + p < push.count; ++p) {
        uint v = p * COMP * MAX4;
        float y = (NUM_LAYERS & 1) == 1 ? pong[v].x : ping[v].x;
#ifdef WITH_GRADIENT
        vec3 dy = (NUM_LAYERS & 1) == 1
                      ? vec3(pong[v + MAX4].x, pong[v + 2 * MAX4].x, pong[v + 3 * MAX4].x)
                      : vec3(ping[v + MAX4].x, ping[v + 2 * MAX4].x, ping[v + 3 * MAX4].x);
        values[push.first + first + p] = vec4(activate_output(y), output_slope(y) * dy);
#else
        values[push.first + first + p] = activate_output(y);
#endif
    }
}
