// Marching cubes, step 2: per parent, its vertices (edge crossings interpolated linearly, in the
// unit frame for the normals' central differences, and in the original frame), and the triangles of its children as indices of the welded vertices. Arithmetic as in
// extract_cpu.cpp, so that both paths place vertices identically for identical field values.
#version 450
#extension GL_GOOGLE_include_directive : require
#include "common.glsl"
#include "extract.glsl"
#include "mc.glsl"
layout(local_size_x = 64) in;
layout(std430, binding = 9) readonly buffer VertexOffsets { uint vertex_offsets[]; };
layout(std430, binding = 10) readonly buffer TriangleOffsets { uint triangle_offsets[]; };
layout(std430, binding = 11) writeonly buffer Positions { float positions[]; };
layout(std430, binding = 12) writeonly buffer UnitPositions { float unit_positions[]; };
// Per vertex: its edge's axis, | 4 when the edge's first (lower) end is inside. normals.comp falls
// back to this direction where the gradient vanishes.
layout(std430, binding = 13) writeonly buffer VertexEdges { uint vertex_edges[]; };
layout(std430, binding = 14) writeonly buffer Indices { uint indices[]; };

void main() {
    uint k = global_invocation_index(64);
    if (k >= push.count) return;
    uint r = push.parent_cells;
    uvec3 p = cell_coords(kept_cells[k], r);
    load_grid(p, k, r);

    uvec2 mask = edge_masks[k];
    uint vertex = vertex_offsets[k];
    for (uint id = 0u; id < 54u; ++id) {
        if (!mask_has(mask, id)) continue;
        uint a;
        uvec3 s;
        edge_from_id(id, a, s);
        uvec3 v = 2u * p + s;
        float fa = grid[local_index(s)], fb = grid[local_index(s + unit_axis(a))];
        vec3 u = child_point(v);
        precise float t = fa / (fa - fb);
        if (!(t >= 0.0 && t <= 1.0)) t = 0.5;  // an infinite corner
        float ub = fine_coordinate(v[a] + 1u, push.step);
        precise float along = u[a] + t * (ub - u[a]);
        u[a] = along;
        precise vec3 x = u * push.scale + push.center.xyz;
        positions[3u * vertex] = x.x;
        positions[3u * vertex + 1u] = x.y;
        positions[3u * vertex + 2u] = x.z;
        unit_positions[3u * vertex] = u.x;
        unit_positions[3u * vertex + 1u] = u.y;
        unit_positions[3u * vertex + 2u] = u.z;
        vertex_edges[vertex] = a | (fa < 0.0 ? 4u : 0u);
        ++vertex;
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
