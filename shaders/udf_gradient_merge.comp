// The gradient list of a level some of whose points another list has (udf_gradient_count.comp).
// Per parent, in list order, each point's (value, gradient) from the fresh evaluations
// (NFD_B_OWNED, NFD_B_OFFSETS: their mask and offsets); compiled with NFD_PREDICTED_VALUES, from
// the meshed level's predicted list, evaluated by the same kernel; else, a corner that the level
// above listed (progressive levels), from that list: the same f32 point (child-grid point v of
// this level is fine vertex v << l, the level above's 2v' << (l - 1)), so the same bits.
#version 450
#extension GL_GOOGLE_include_directive : require
#include "common.glsl"
#include "extract.glsl"
// Written here: declared before udf.glsl, whose declaration is read-only.
#define UDF_GRADIENTS_WRITTEN
layout(std430, binding = NFD_B_GRADIENTS) buffer Gradients { vec4 gradients[]; };
#include "udf.glsl"
layout(std430, binding = NFD_B_CORNER_GRADIENTS) readonly buffer CornerGradients {
    uint corner_gradients[];
};
layout(std430, binding = NFD_B_ABOVE_GRADIENTS) readonly buffer AboveGradients {
    vec4 above_gradients[];
};
layout(std430, binding = NFD_B_FRESH_GRADIENTS) readonly buffer FreshGradients {
    vec4 fresh_gradients[];
};

void main() {
    uint k = global_invocation_index(gl_WorkGroupSize.x);
    if (k >= item_count()) return;
    // The parent's masks and offsets loaded once (the compiler cannot hoist them past the
    // stores: the buffers might alias), then the listed points only.
    uint mask = gradient_owned[k], fresh = owned[k];
    uint to = gradient_offsets[k], from = offsets[k];
#ifdef NFD_PREDICTED_VALUES
    uint predicted_mask = predicted_owned[k], predicted_offset = predicted_offsets[k];
#endif
    for (uint m = mask; m != 0u; m &= m - 1u) {
        uint l = uint(findLSB(m)), bit = 1u << l;
        uvec3 local = uvec3(l % 3u, (l / 3u) % 3u, l / 9u);
        if ((fresh & bit) != 0u) {
            gradients[to++] = fresh_gradients[from++];
#ifdef NFD_PREDICTED_VALUES
        } else if ((predicted_mask & bit) != 0u) {
            gradients[to++] = predicted[predicted_offset + bitCount(predicted_mask & (bit - 1u))];
#endif
        } else {
            gradients[to++] = above_gradients[corner_gradients[8u * k + corner_index(local)]];
        }
    }
}
