// SDF marching cubes, step 3: per vertex, its position (the edge crossing, interpolated linearly,
// in the original frame) and normal (mc.glsl's edge_normal), from the edge mc_emit recorded. One
// vertex per invocation keeps the SIMD lanes of CPU implementations busy. Arithmetic as in
// mesh_sdf_cpu.cpp and extract_cpu.cpp, so that both paths place vertices identically for
// identical field values.
#version 450
#extension GL_GOOGLE_include_directive : require
#include "common.glsl"
#include "extract.glsl"
#include "mc.glsl"
layout(std430, binding = NFD_B_VERTEX_EDGES) readonly buffer VertexEdges { uint vertex_edges[]; };
layout(std430, binding = NFD_B_POSITIONS) writeonly buffer Positions { float positions[]; };
layout(std430, binding = NFD_B_NORMALS) writeonly buffer Normals { float normals[]; };

void main() {
    uint vertex = global_invocation_index(gl_WorkGroupSize.x);
    if (vertex >= item_count()) return;
    uint r = push.parent_cells;
    uint k = vertex_edges[vertex] >> 6;
    uvec3 p = cell_coords(kept_cells[k], r);
    uint a;
    uvec3 s;
    edge_from_id(vertex_edges[vertex] & 63u, a, s);
    uvec3 v = 2u * p + s;
    uint around = kept_arounds[k];
    float fa = child_grid_value(p, k, around, s, r);
    float fb = child_grid_value(p, k, around, s + unit_axis(a), r);
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
    vec3 n = edge_normal(s, a, fa, fb, t, p, k, around, r);
    normals[3u * vertex] = n.x;
    normals[3u * vertex + 1u] = n.y;
    normals[3u * vertex + 2u] = n.z;
}
