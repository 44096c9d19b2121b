// Marching cubes, step 2: per parent, the edges of its vertices (for mc_vertices.comp) and the
// triangles of its children as indices of the welded vertices. Reads the child grids from
// mc_classify's `child_grids` only: extract.glsl's bindings 3-6 are not used (nor kept alive).
#version 450
#extension GL_GOOGLE_include_directive : require
#include "common.glsl"
#include "extract.glsl"
#include "mc.glsl"
layout(local_size_x = 64) in;
layout(std430, binding = 10) readonly buffer VertexOffsets { uint vertex_offsets[]; };
layout(std430, binding = 11) readonly buffer TriangleOffsets { uint triangle_offsets[]; };
layout(std430, binding = 12) writeonly buffer VertexEdges { uint vertex_edges[]; };  // k << 6 | id
layout(std430, binding = 13) writeonly buffer Indices { uint indices[]; };

void main() {
    uint k = global_invocation_index(64);
    if (k >= push.count) return;
    uint r = push.parent_cells;
    uvec3 p = cell_coords(kept_cells[k], r);
    reload_grid(k);

    // One loop iteration per vertex would leave most SIMD lanes idle (a parent has about one):
    // mc_vertices.comp does the per-vertex work, one vertex per invocation.
    uvec2 mask = edge_masks[k];
    uint vertex = vertex_offsets[k];
    while (mask != uvec2(0u)) {
        uint id = mask.x != 0u ? uint(findLSB(mask.x)) : 32u + uint(findLSB(mask.y));
        if (id < 32u) mask.x &= mask.x - 1u;
        else mask.y &= mask.y - 1u;
        vertex_edges[vertex++] = k << 6 | id;
    }

    uint index = 3u * triangle_offsets[k];
    for (uint child = 0u; child < 8u; ++child) {
        uvec3 d = corner_offset(child);
        if (!child_cell_exists(2u * p + d)) continue;
        uint cc = cube_case(d);
        uint n = 3u * mc_triangle_count(cc);
        for (uint i = 0u; i < n; ++i) {
            uint e = uint(mc_triangle_edge(cc, i));
            uint a = e / 4u;
            uvec3 v = 2u * p + d + corner_offset(mc_edge_start_corner(e));
            uvec3 o = edge_owner(v, a, r);
            uint ko = kept_rank(cell_index(o, r));
            indices[index++] = vertex_offsets[ko] + mask_rank(edge_masks[ko], edge_id(a, v - 2u * o));
        }
    }
}
