// UDF, steps 2, 3 and 5 (extract.h; udf.glsl): per near child of each parent, the orientation n
// from the gradient at its lowest corner, the pseudo-signed cube case, and which of its table
// triangles have three valid edges. The edges of the emitted triangles are marked in their
// owners' edge masks (atomically: several cells share an edge, and unlike an SDF's, whether a
// UDF's edge carries a vertex depends on its cells), which mc_emit.comp then numbers.
#version 450
#extension GL_GOOGLE_include_directive : require
#include "common.glsl"
#include "extract.glsl"
#include "mc.glsl"
#include "udf.glsl"
layout(std430, binding = NFD_B_TRIANGLE_COUNTS) writeonly buffer TriangleCounts {
    uint triangle_counts[];
};
layout(std430, binding = NFD_B_ACTIVE) buffer ActiveCells { uint active_cells; };

void main() {
    uint k = global_invocation_index(gl_WorkGroupSize.x);
    if (k >= item_count()) return;
    uint r = push.parent_cells;
    uvec3 p = cell_coords(kept_cells[k], r);
    uint near = near_masks[k];
    uint around = near != 0u ? kept_around(p, r) : 0u;
    uint own_mask = near != 0u ? gradient_owned[k] : 0u;
    uint own_offset = near != 0u ? gradient_offsets[k] : 0u;
    uint triangles = 0u, busy = 0u;
    uvec4 c = uvec4(0u);
    for (uint child = 0u; child < 8u; ++child) {
        if ((near & (1u << child)) == 0u) continue;
        uvec3 d = corner_offset(child);
        float f[8];
        vec3 g[8];
        float f_nearest = 0.0;
        vec3 g_nearest = vec3(0.0);
        for (uint i = 0u; i < 8u; ++i) {
            uvec3 l = d + corner_offset(i);
            uvec3 o = owner_around(around, l, 3u);
            vec4 fg;
            if (all(equal(o, uvec3(1u)))) {  // p's own point: its mask and offset loaded once
                uint bit = 1u << local_index(l);
                fg = gradients[own_offset + bitCount(own_mask & (bit - 1u))];
            } else {
                fg = field_at(p, k, around, l, r);
            }
            f[i] = fg.x;
            g[i] = fg.yzw;
            bool nearer = i == 0u || fg.x < f_nearest;  // the first of the smallest values
            f_nearest = nearer ? fg.x : f_nearest;
            g_nearest = nearer ? fg.yzw : g_nearest;
        }
        vec3 n;
        if (!canonical_direction(g_nearest, n)) continue;  // step 2
        uint cc = 0u;
        [[unroll]] for (uint i = 0u; i < 8u; ++i)  // step 3
            if (dot3(g[i], n) < 0.0) cc |= 1u << i;
        uint valid_edges = valid_edge_mask(f, push.edge_limit);  // step 5's test, per cube edge
        uint emitted = 0u;
        for (uint t = 0u; t < mc_triangle_count(cc); ++t) {
            bool valid = true;  // step 5
            for (uint j = 0u; j < 3u; ++j)
                valid = valid && (valid_edges >> uint(mc_triangle_edge(cc, 3u * t + j)) & 1u) != 0u;
            if (!valid) continue;
            emitted |= 1u << t;
            for (uint j = 0u; j < 3u; ++j) {
                uint e = uint(mc_triangle_edge(cc, 3u * t + j));
                uint a = e / 4u;
                uvec3 l = d + corner_offset(mc_edge_start_corner(e));
                uvec3 v = 2u * p + l;
                uint ko;
                uvec3 o = local_owner(p, k, around, l, a, r, ko);
                uint id = edge_id(a, v - 2u * o);
                if (id < 32u) atomicOr(edge_masks[ko].x, 1u << id);
                else atomicOr(edge_masks[ko].y, 1u << (id - 32u));
            }
        }
        set_case_byte(c, child, cc);
        set_case_byte(c, 8u + child, emitted);
        triangles += bitCount(emitted);
        busy += emitted != 0u ? 1u : 0u;
    }
    cases[k] = c;
    triangle_counts[k] = triangles;
    if (busy > 0u) atomicAdd(active_cells, busy);
}
