// Marching cubes, step 2, for both field types (mc.glsl): per parent, the edges of its vertices
// (for mc_vertices.comp / udf_vertices.comp) and its children's emitted triangles as indices of
// the welded vertices, from what the classify kernel wrote.
#version 450
#extension GL_GOOGLE_include_directive : require
#include "common.glsl"
#include "extract.glsl"
#include "mc.glsl"
layout(std430, binding = NFD_B_VERTEX_OFFSETS) readonly buffer VertexOffsets {
    uint vertex_offsets[];
};
layout(std430, binding = NFD_B_TRIANGLE_OFFSETS) readonly buffer TriangleOffsets {
    uint triangle_offsets[];
};
layout(std430, binding = NFD_B_VERTEX_EDGES) writeonly buffer VertexEdges {
    uint vertex_edges[];  // k << 6 | id
};
layout(std430, binding = NFD_B_INDICES) writeonly buffer Indices { uint indices[]; };

void main() {
    uint k = global_invocation_index(gl_WorkGroupSize.x);
    if (k >= item_count()) return;
    uint r = push.parent_cells;
    uvec3 p = cell_coords(kept_cells[k], r);

    // One loop iteration per vertex would leave most SIMD lanes idle (a parent has about one):
    // the vertices kernel does the per-vertex work, one vertex per invocation.
    uvec2 mask = edge_masks[k];
    uint vertex = vertex_offsets[2u * k];
    while (mask != uvec2(0u)) {
        uint id = mask.x != 0u ? uint(findLSB(mask.x)) : 32u + uint(findLSB(mask.y));
        if (id < 32u) mask.x &= mask.x - 1u;
        else mask.y &= mask.y - 1u;
        vertex_edges[vertex++] = k << 6 | id;
    }

    uvec4 c = cases[k];
    uint around = (c.z | c.w) != 0u ? kept_around(p, r) : 0u;  // any triangle emitted
    uint index = 3u * triangle_offsets[k];
    for (uint child = 0u; child < 8u; ++child) {
        uint emitted = case_byte(c, 8u + child);
        if (emitted == 0u) continue;
        uint cc = case_byte(c, child);
        uvec3 d = corner_offset(child);
        for (uint t = 0u; t < mc_triangle_count(cc); ++t) {
            if ((emitted & (1u << t)) == 0u) continue;
            for (uint j = 0u; j < 3u; ++j) {
                uint e = uint(mc_triangle_edge(cc, 3u * t + j));
                uint a = e / 4u;
                uvec3 l = d + corner_offset(mc_edge_start_corner(e));
                uvec3 v = 2u * p + l;
                uint ko;
                uvec3 o = local_owner(p, k, around, l, a, r, ko);
                indices[index++] =
                    vertex_offsets[2u * ko] + mask_rank(edge_masks[ko], edge_id(a, v - 2u * o));
            }
        }
    }
}
