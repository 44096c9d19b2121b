// UDF, steps 2, 3 and 5 (extract.h; udf.glsl): per near cell (one invocation each, from the list
// of near cells: a parent has about two of its eight children near, so an invocation per parent
// looping over its children left most SIMD lanes idle, on lavapipe and on GPUs alike), the
// orientation n from the gradient at its nearest corner, the pseudo-signed cube case, and which of
// its table triangles have three valid edges. The case and emitted bytes go to the parent's
// `cases` (zero before, atomically: a parent's near children run in different invocations), the
// edges of the emitted triangles to their owners' edge masks (atomically: several cells share an
// edge, and unlike an SDF's, whether a UDF's edge carries a vertex depends on its cells), which
// mc_emit.comp then numbers.
#version 450
#extension GL_GOOGLE_include_directive : require
#include "common.glsl"
#include "extract.glsl"
#include "mc.glsl"
#include "udf.glsl"
layout(std430, binding = NFD_B_TRIANGLE_COUNTS) buffer TriangleCounts {
    uint triangle_counts[];
};

layout(std430, binding = NFD_B_NEAR_CELLS) readonly buffer NearCells { uint near_cells[]; };

void main() {
    uint i = global_invocation_index(gl_WorkGroupSize.x);
    if (i >= item_count()) return;
    uint k = near_cells[i] >> 5u, child = near_cells[i] & 31u;
    uint r = push.parent_cells;
    uvec3 p = cell_coords(kept_cells[k], r);
    uint around = kept_arounds[k];
    uint own_mask = gradient_owned[k], own_offset = gradient_offsets[k];
    uvec3 d = corner_offset(child);
    float f[8];
    vec3 g[8];
    float f_nearest = 0.0;
    vec3 g_nearest = vec3(0.0);
    for (uint c = 0u; c < 8u; ++c) {
        uvec3 l = d + corner_offset(c);
        uvec3 o = owner_around(around, l, 3u);
        vec4 fg;
        if (all(equal(o, uvec3(1u)))) {  // p's own point: its mask and offset loaded once
            uint bit = 1u << local_index(l);
            fg = gradients[own_offset + bitCount(own_mask & (bit - 1u))];
        } else {  // a neighbour's: its rank, then its list (the owner found once)
            uvec3 owner = p + o - 1u;
            fg = gradients[listed_gradient(2u * p + l, owner, kept_rank(cell_index(owner, r)))];
        }
        f[c] = fg.x;
        g[c] = fg.yzw;
        bool nearer = c == 0u || fg.x < f_nearest;  // the first of the smallest values
        f_nearest = nearer ? fg.x : f_nearest;
        g_nearest = nearer ? fg.yzw : g_nearest;
    }
    vec3 n;
    if (!canonical_direction(g_nearest, n)) return;  // step 2: case and mask stay 0
    uint cc = 0u;
    [[unroll]] for (uint c = 0u; c < 8u; ++c)  // step 3
        if (dot3(g[c], n) < 0.0) cc |= 1u << c;
    uint valid_edges = valid_edge_mask(f, push.edge_limit);  // step 5's test, per cube edge
    uint emitted = 0u, used_edges = 0u;
    uvec2 triangle_edges = mc_triangle_edge_masks(cc);
    for (uint t = 0u; t < mc_triangle_count(cc); ++t) {
        uint edges = mc_triangle_edge_mask(triangle_edges, t);
        if ((edges & valid_edges) != edges) continue;  // step 5
        emitted |= 1u << t;
        used_edges |= edges;
    }
    // Each edge of the emitted triangles once (a cell's triangles share most of theirs).
    uvec2 own_edges = uvec2(0u);  // the parent's own (most of them): one atomic per word below
    for (uint m = used_edges; m != 0u; m &= m - 1u) {
        uint e = uint(findLSB(m));
        uint a = e / 4u;
        uvec3 l = d + corner_offset(mc_edge_start_corner(e));
        uvec3 v = 2u * p + l;
        uint ko;
        uvec3 o = local_owner(p, k, around, l, a, r, ko);
        uint id = edge_id(a, v - 2u * o);
        if (ko == k) own_edges |= id < 32u ? uvec2(1u << id, 0u) : uvec2(0u, 1u << (id - 32u));
        else if (id < 32u) atomicOr(edge_masks[ko].x, 1u << id);
        else atomicOr(edge_masks[ko].y, 1u << (id - 32u));
    }
    if (own_edges.x != 0u) atomicOr(edge_masks[k].x, own_edges.x);
    if (own_edges.y != 0u) atomicOr(edge_masks[k].y, own_edges.y);
    // mc.glsl's case_byte layout: byte `child` the case, byte 8 + child the emitted mask.
    if (cc != 0u) atomicOr(cases[k][child >> 2], cc << (8u * (child & 3u)));
    if (emitted != 0u) {
        atomicOr(cases[k][2u + (child >> 2)], emitted << (8u * (child & 3u)));
        atomicAdd(triangle_counts[k], bitCount(emitted));
        atomicOr(emitting[k], 1u << child);
    }
}
