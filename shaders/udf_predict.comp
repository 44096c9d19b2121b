// UDF, a level's value pass: per parent, which of the new points it owns (NFD_B_OWNED, from
// refine_count) are likely corners of near cells, the points whose gradients the mesher will
// need (udf.glsl). Those move to the predicted list (NFD_B_PREDICTED_OWNED), which the gradient
// kernel evaluates (value and gradient, the value bit-identical to the value kernel's), and leave
// the value list. A guess only decides which kernel evaluates a point, never a value: the
// trilinear interpolation of the parent's corner values at the point at most push.threshold
// (NaN corners: the point is not predicted).
//
// Compiled with NFD_PREDICT_JOIN, the way back for a level that is refined further (a meshed level
// of a progressive extraction, above the finest): once both lists are evaluated, each parent's
// values in local order, from either list, into NFD_B_JOINED_VALUES, and its mask and offset of
// the whole list in place of the value list's (the lists are disjoint, so the joined offset is the
// sum of the two). Dispatched over the parents' capacity: the offsets past the last parent become
// the joined total too.
#version 450
#extension GL_GOOGLE_include_directive : require
#include "common.glsl"
#ifdef NFD_PREDICT_JOIN
#define NFD_PREDICTED_VALUES
#endif
#include "extract.glsl"

#ifdef NFD_PREDICT_JOIN
layout(std430, binding = NFD_B_JOINED_VALUES) writeonly buffer Joined { float joined[]; };

void main() {
    uint k = global_invocation_index(gl_WorkGroupSize.x);
    if (k >= item_count()) return;
    uint listed = owned[k], guessed = predicted_owned[k];
    uint from = offsets[k], from_guessed = predicted_offsets[k], to = from + from_guessed;
    offsets[k] = to;
    owned[k] = listed | guessed;
    for (uint rest = listed | guessed; rest != 0u; rest &= rest - 1u) {
        uint bit = 1u << uint(findLSB(rest));
        joined[to++] = (guessed & bit) != 0u ? predicted[from_guessed++].x : values[from++];
    }
}
#else
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
#endif
