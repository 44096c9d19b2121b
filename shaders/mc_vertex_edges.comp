// Marching cubes, step 2 of 3, for both field types (mc.glsl): per parent, the edges of the
// vertices it owns (k << 6 | edge id, in the order of its edge mask), which mc_vertices.comp /
// udf_vertices.comp then place, one vertex per invocation.
#version 450
#extension GL_GOOGLE_include_directive : require
#include "common.glsl"
#include "extract.glsl"
#include "mc.glsl"
layout(std430, binding = NFD_B_VERTEX_OFFSETS) readonly buffer VertexOffsets {
    uint vertex_offsets[];
};
layout(std430, binding = NFD_B_VERTEX_EDGES) writeonly buffer VertexEdges { uint vertex_edges[]; };

void main() {
    uint k = global_invocation_index(gl_WorkGroupSize.x);
    if (k >= item_count()) return;
    uvec2 mask = edge_masks[k];
    uint vertex = vertex_offsets[2u * k];
    while (mask != uvec2(0u)) {
        uint id = mask.x != 0u ? uint(findLSB(mask.x)) : 32u + uint(findLSB(mask.y));
        if (id < 32u) mask.x &= mask.x - 1u;
        else mask.y &= mask.y - 1u;
        vertex_edges[vertex++] = k << 6 | id;
    }
}
