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
    uvec2 own_mask = edge_masks[k];
    uint own_first = vertex_offsets[2u * k];
    uvec2 mask = own_mask;
    uint vertex = own_first;
    while (mask != uvec2(0u)) {
        uint id = mask.x != 0u ? uint(findLSB(mask.x)) : 32u + uint(findLSB(mask.y));
        if (id < 32u) mask.x &= mask.x - 1u;
        else mask.y &= mask.y - 1u;
        vertex_edges[vertex++] = k << 6 | id;
    }

    // One loop over the parent's emitted triangles (bit 8 i + t of c.zw: child i's table triangle
    // t) rather than loops over children and their triangles, whose counts differ from lane to
    // lane; the parent's own vertices (most) without loads.
    uvec4 c = cases[k];
    uint around = kept_arounds[k];
    uint index = 3u * triangle_offsets[k];
    uvec2 emitted = c.zw;
    while (emitted != uvec2(0u)) {
        uint bit = emitted.x != 0u ? uint(findLSB(emitted.x)) : 32u + uint(findLSB(emitted.y));
        if (bit < 32u) emitted.x &= emitted.x - 1u;
        else emitted.y &= emitted.y - 1u;
        uint child = bit / 8u, t = bit % 8u;
        uint cc = case_byte(c, child);
        uvec3 d = corner_offset(child);
        [[unroll]] for (uint j = 0u; j < 3u; ++j) {
            uint e = uint(mc_triangle_edge(cc, 3u * t + j));
            uint a = e / 4u;
            uvec3 l = d + corner_offset(mc_edge_start_corner(e));
            uvec3 o = owner_around(around, l, a);
            uint id = edge_id(a, l + 2u - 2u * o);
            if (all(equal(o, uvec3(1u)))) {
                indices[index++] = own_first + mask_rank(own_mask, id);
            } else {
                uint ko = kept_rank(cell_index(p + o - 1u, r));
                indices[index++] = vertex_offsets[2u * ko] + mask_rank(edge_masks[ko], id);
            }
        }
    }
}
