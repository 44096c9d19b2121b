// Marching cubes, step 2 of 3, for both field types (mc.glsl): per cell that emits a triangle
// (the list `cells`, 32 * parent rank + child, in order), its emitted triangles as indices of the
// welded vertices, from what the classify kernel wrote. One cell per invocation: a parent's
// triangles (0 to 40, a busy one ~8) in one invocation left most SIMD lanes waiting for the
// busiest parent of their group, on lavapipe and on GPUs alike.
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
layout(std430, binding = NFD_B_NEAR_CELLS) readonly buffer Cells { uint cells[]; };
layout(std430, binding = NFD_B_INDICES) writeonly buffer Indices { uint indices[]; };

void main() {
    uint i = global_invocation_index(gl_WorkGroupSize.x);
    if (i >= item_count()) return;
    uint k = cells[i] >> 5u, child = cells[i] & 31u;
    uint r = push.parent_cells;
    uvec3 p = cell_coords(kept_cells[k], r);
    // A parent's triangles are its children's in order, each child's in table order (bit 8 i + t
    // of c.zw: child i's table triangle t): this child's start after the earlier children's.
    uvec4 c = cases[k];
    uint below = 8u * child;
    uint earlier = below < 32u ? bitCount(c.z & ((1u << below) - 1u))
                               : bitCount(c.z) + bitCount(c.w & ((1u << (below - 32u)) - 1u));
    uint index = 3u * (triangle_offsets[k] + earlier);
    uint around = kept_arounds[k];
    uvec2 own_mask = edge_masks[k];
    uint own_first = vertex_offsets[2u * k];
    uint cc = case_byte(c, child);
    uvec3 d = corner_offset(child);
    uint emitted = case_byte(c, 8u + child);
    // The vertex of each edge the emitted triangles use, once per edge (a cell's triangles share
    // most of theirs).
    uvec2 triangle_edges = mc_triangle_edge_masks(cc);
    uint used = 0u;
    for (uint m = emitted; m != 0u; m &= m - 1u)
        used |= mc_triangle_edge_mask(triangle_edges, uint(findLSB(m)));
    uint vertex[12];
    for (uint m = used; m != 0u; m &= m - 1u) {
        uint e = uint(findLSB(m));
        uint a = e / 4u;
        uvec3 l = d + corner_offset(mc_edge_start_corner(e));
        uvec3 o = owner_around(around, l, a);
        uint id = edge_id(a, l + 2u - 2u * o);
        if (all(equal(o, uvec3(1u)))) {  // the parent's own vertex (most): no loads
            vertex[e] = own_first + mask_rank(own_mask, id);
        } else {
            uint ko = kept_rank(cell_index(p + o - 1u, r));
            vertex[e] = vertex_offsets[2u * ko] + mask_rank(edge_masks[ko], id);
        }
    }
    for (; emitted != 0u; emitted &= emitted - 1u) {
        uint t = uint(findLSB(emitted));
        [[unroll]] for (uint j = 0u; j < 3u; ++j) indices[index++] = vertex[mc_triangle_edge(cc, 3u * t + j)];
    }
}
