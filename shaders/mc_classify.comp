// Marching cubes, step 1: per parent, the crossed edges it owns (its vertices) and the number of
// triangles of its children; the host prefix-sums both counts. Also stores the parent's child grid
// (mc.glsl's child_grids) for mc_emit.
#version 450
#extension GL_GOOGLE_include_directive : require
#include "common.glsl"
#include "extract.glsl"
#include "mc.glsl"
layout(local_size_x = 64) in;
layout(std430, binding = 10) writeonly buffer VertexCounts { uint vertex_counts[]; };
layout(std430, binding = 11) writeonly buffer TriangleCounts { uint triangle_counts[]; };
layout(std430, binding = 12) buffer ActiveCells { uint active_cells; };  // cells with triangles

void main() {
    uint k = global_invocation_index(64);
    if (k >= push.count) return;
    uint r = push.parent_cells;
    uvec3 p = cell_coords(kept_cells[k], r);
    load_grid(p, k, r);
    uint triangles = 0u, busy = 0u;
    for (uint child = 0u; child < 8u; ++child) {
        uvec3 d = corner_offset(child);
        if (!child_cell_exists(2u * p + d)) continue;
        uint n = mc_triangle_count(cube_case(d));
        triangles += n;
        busy += n > 0u ? 1u : 0u;
    }
    uvec2 mask = uvec2(0u);
    for (uint id = 0u; id < 54u; ++id) {
        uint a;
        uvec3 s;
        edge_from_id(id, a, s);
        uvec3 e = unit_axis(a);
        if (!child_point_exists(2u * p + s + e) || inside(s) == inside(s + e)) continue;
        if (any(notEqual(edge_owner(2u * p + s, a, r), p))) continue;
        if (id < 32u) mask.x |= 1u << id;
        else mask.y |= 1u << (id - 32u);
    }
    edge_masks[k] = mask;
    vertex_counts[k] = bitCount(mask.x) + bitCount(mask.y);
    triangle_counts[k] = triangles;
    if (busy > 0u) atomicAdd(active_cells, busy);
}
