// SDF marching cubes, step 1 (mc.glsl): per parent, each child's cube case (all its table
// triangles are emitted), the crossed edges it owns (its vertices) and its triangle count; the
// host prefix-sums the counts. refine_cells.comp's NFD_MC_CASES variant (the mc_classify kernel)
// runs it on the child grid its keep rule reads: a meshed level above the finest is classified
// as it is refined, and its mesher reads the grids no second time.
#ifndef NFD_MC_CLASSIFY_GLSL
#define NFD_MC_CLASSIFY_GLSL
#include "mc.glsl"
layout(std430, binding = NFD_B_TRIANGLE_COUNTS) writeonly buffer TriangleCounts {
    uint triangle_counts[];
};

// Kept parent k at p, with kept-neighbour bits `around` and child grid `values` (local_index
// order, 0 where a point does not exist).
void classify_parent(uint k, uvec3 p, uint around, float values[27]) {
    // The signs and existence of the 27 points as bit masks (bit local_index(l)), for the cases
    // and the crossed edges.
    uint inside_bits = 0u, exist_bits = 0u;
    [[unroll]] for (uint l = 0u; l < 27u; ++l) {
        if (values[l] < 0.0) inside_bits |= 1u << l;
        if (child_point_exists(2u * p + uvec3(l % 3u, (l / 3u) % 3u, l / 9u))) exist_bits |= 1u << l;
    }
    uint triangles = 0u, emits = 0u;
    uvec4 c = uvec4(0u);
    for (uint child = 0u; child < 8u; ++child) {
        uvec3 d = corner_offset(child);
        if (!child_cell_exists(2u * p + d)) continue;
        uint cc = cube_case(inside_bits, d);
        uint n = mc_triangle_count(cc);
        set_case_byte(c, child, cc);
        set_case_byte(c, 8u + child, (1u << n) - 1u);
        triangles += n;
        emits |= n > 0u ? 1u << child : 0u;
    }
    // The crossed edges the parent owns, on bits: crossed from the signs, less those an earlier
    // kept neighbour owns. (A loop over the 54 edges with owner_around for each was a quarter of
    // mc_classify on lavapipe.)
    uvec2 mask = uvec2(0u);
    [[unroll]] for (uint id = 0u; id < 54u; ++id) {
        uint a;
        uvec3 s;
        edge_from_id(id, a, s);
        uint from = local_index(s), to = local_index(s + unit_axis(a));
        if (((inside_bits >> from ^ inside_bits >> to) & exist_bits >> to & 1u) == 0u) continue;
        if (id < 32u) mask.x |= 1u << id;
        else mask.y |= 1u << (id - 32u);
    }
    mask &= ~edges_owned_elsewhere(around);
    cases[k] = c;
    edge_masks[k] = mask;
    triangle_counts[k] = triangles;
    emitting[k] = emits;
}

#endif
