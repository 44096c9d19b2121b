// UDF, the finest level's value pass: per parent, which of the new points it owns (NFD_B_OWNED,
// from refine_count) are likely corners of near cells, the points whose gradients the mesher will
// need (udf.glsl). Those move to the predicted list (NFD_B_PREDICTED_OWNED), which the gradient
// kernel evaluates (value and gradient, the value bit-identical to the value kernel's), and leave
// the value list. A guess only decides which kernel evaluates a point, never a value: the
// trilinear interpolation of the parent's corner values at the point at most push.threshold
// (NaN corners: the point is not predicted).
#version 450
#extension GL_GOOGLE_include_directive : require
#include "common.glsl"
#include "extract.glsl"
layout(std430, binding = NFD_B_PREDICTED_OWNED) writeonly buffer PredictedOwned {
    uint predicted_owned[];
};

void main() {
    uint k = global_invocation_index(gl_WorkGroupSize.x);
    if (k >= item_count()) return;
    float c[8];
    for (uint i = 0u; i < 8u; ++i) c[i] = corners[8u * k + i];
    uint mask = owned[k], predicted = 0u;
    for (uint rest = mask; rest != 0u; rest &= rest - 1u) {
        uint l = uint(findLSB(rest));
        vec3 t = 0.5 * vec3(l % 3u, (l / 3u) % 3u, l / 9u);
        vec4 x = mix(vec4(c[0], c[2], c[4], c[6]), vec4(c[1], c[3], c[5], c[7]), t.x);
        vec2 y = mix(x.xz, x.yw, t.y);
        if (mix(y.x, y.y, t.z) <= push.threshold) predicted |= 1u << l;
    }
    owned[k] = mask & ~predicted;
    predicted_owned[k] = predicted;
}
