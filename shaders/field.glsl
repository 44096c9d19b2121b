// The network's interface shared by the field kernels (field_eval.comp, field_eval_lanes.comp):
// their specialization constants (field.cpp, network_layout, fills 0-13; the kernel's points per
// invocation is 14, its local size 15), the points, frequencies and weight blocks they read, and
// the output activation. Weight layout: field_eval.comp's header. Defining WEIGHTS_IN_STORAGE_BUFFER
// gives the weight blocks for layers larger than the device's maxUniformBufferRange.
#ifndef NFD_FIELD_GLSL
#define NFD_FIELD_GLSL
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
layout(constant_id = 13) const uint OUTPUTS = 1;     // 1 (geometry) or 3 (colour); at most 4
layout(constant_id = 14) const uint POINTS = 8;      // points per invocation
// 15: the local size (NFD_FIELD_LOCAL_SIZE_ID).
layout(local_size_x_id = NFD_FIELD_LOCAL_SIZE_ID) in;

const uint ENC4 = 1 + 6 * FREQ4;

layout(std430, binding = NFD_B_FIELD_POINTS) readonly buffer Points { float points[]; };
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

// Point i of the input is result first + i: a long list is evaluated in chunks of points. The
// chunk holds push.count points at most, and fewer when counter push.count_slot says so.
// ball_radius_sq and ball_floor: the shape's ball where the field is gridded (network.h,
// ShapeBall), an infinite radius elsewhere.
layout(push_constant) uniform Push {
    uint count;
    uint first;
    uint count_slot;
    float ball_radius_sq;
    float ball_floor;
} push;

// A value at point u, raised to the floor beyond the ball (ShapeBall::bound; a NaN stays).
float bounded(float value, vec3 u) {
    precise float s = u.x * u.x + u.y * u.y + u.z * u.z;
    return s > push.ball_radius_sq && value < push.ball_floor ? push.ball_floor : value;
}

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

#endif
