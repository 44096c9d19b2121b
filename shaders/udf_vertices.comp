// UDF, steps 4 and 6 (extract.h; udf.glsl): per vertex, its position at t = f_a / (f_a + f_b)
// along its edge (the minimum of the V-shaped |distance|; 0.5 when the sum is 0), in the original
// frame, and its normal, normalize(g_a - g_b) in canonical direction (the edge axis where that is
// zero or not finite). Arithmetic as in mesh_udf_cpu.cpp and extract_cpu.cpp.
#version 450
#extension GL_GOOGLE_include_directive : require
#include "common.glsl"
#include "extract.glsl"
#include "mc.glsl"
#include "udf.glsl"
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
    uvec3 v = 2u * p + s, e = unit_axis(a);
    uint around = kept_arounds[k];
    vec4 a_end = field_at(p, k, around, s, r), b_end = field_at(p, k, around, s + e, r);
    float fa = a_end.x, fb = b_end.x;
    precise float sum = fa + fb;
    precise float t = sum > 0.0 ? fa / sum : 0.5;
    vec3 u = child_point(v);
    float ub = fine_coordinate(v[a] + 1u, push.step);
    precise float along = u[a] + t * (ub - u[a]);
    u[a] = along;
    precise vec3 x = u * push.scale + push.center.xyz;
    positions[3u * vertex] = x.x;
    positions[3u * vertex + 1u] = x.y;
    positions[3u * vertex + 2u] = x.z;

    precise vec3 d = a_end.yzw - b_end.yzw;
    vec3 m;
    float len = sqrt(dot3(d, d));
    vec3 n = vec3(e);
    if (canonical_direction(d, m) && len > 0.0 && !isinf(len)) n = m / len;
    normals[3u * vertex] = n.x;
    normals[3u * vertex + 1u] = n.y;
    normals[3u * vertex + 2u] = n.z;
}
