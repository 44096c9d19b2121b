// The coarsest level's point lists from the host's evaluation (levels.cpp, evaluate_top_on_host):
// the field at every vertex of that level, (push.child_cells + 1)^3 of them in raster order, with
// COMPONENTS floats each (1: values; 4: value and gradient, field_eval's gradient output). Each
// listed point (extract.glsl, listed_point) copies its vertex's, in list order, from push.first
// on: the list as refine_points + field_eval would have filled it, without the network's
// pipelines.
#version 450
#extension GL_GOOGLE_include_directive : require
#include "common.glsl"
#include "extract.glsl"
layout(constant_id = 0) const uint COMPONENTS = 1u;
layout(std430, binding = NFD_B_DENSE_VALUES) readonly buffer Dense { float dense[]; };
layout(std430, binding = NFD_B_POINTS) writeonly buffer Results { float results[]; };

void main() {
    uint j = global_invocation_index(gl_WorkGroupSize.x);
    if (j >= item_count()) return;
    uint i = push.first + j;
    uvec3 v = listed_point(i);
    uint side = push.child_cells + 1u;
    uint vertex = (v.z * side + v.y) * side + v.x;
    for (uint c = 0u; c < COMPONENTS; ++c)
        results[COMPONENTS * i + c] = dense[COMPONENTS * vertex + c];
}
