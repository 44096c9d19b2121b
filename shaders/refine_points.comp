// Refinement, step 2: the unit-frame positions of the points of a point list (extract.glsl) from
// push.first on, push.count of them at most (a chunk of the list that field_eval.comp then
// evaluates; the total is in counter push.count_slot). One point per invocation.
#version 450
#extension GL_GOOGLE_include_directive : require
#include "common.glsl"
#include "extract.glsl"
layout(std430, binding = NFD_B_POINTS) writeonly buffer Points { float points[]; };

void main() {
    uint j = global_invocation_index(gl_WorkGroupSize.x);
    if (j >= item_count()) return;
    vec3 u = child_point(listed_point(push.first + j));
    points[3u * j] = u.x;
    points[3u * j + 1u] = u.y;
    points[3u * j + 2u] = u.z;
}
