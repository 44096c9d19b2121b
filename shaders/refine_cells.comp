// Refinement, step 3: tests the children of each kept parent with the activity test of
// extract.h and sets the kept ones in the child level's bitmap (cleared by the host).
// NFD_NEAR_MASKS, for a UDF level that is meshed before the next one refines it (progressive
// extractions): also each parent's near children (udf_near.comp's test on the same eight
// values, push.edge_limit the mesher's), so that the mesher skips udf_near's pass over the grid.
// NFD_MC_CASES (the mc_classify kernel): each parent's marching-cubes classification
// (mc_classify.glsl), the SDF mesher's first step, and on a level above the finest (child level
// > 0: meshed in a progressive extraction before the next level refines it) the keep rule too,
// from one read of the child grid. On the finest level nothing is kept (CHILD_BITS unused).
#version 450
#extension GL_GOOGLE_include_directive : require
#include "common.glsl"
#include "extract.glsl"
layout(std430, binding = NFD_B_CHILD_BITS) buffer ChildBits { uint child_bits[]; };
#ifdef NFD_NEAR_MASKS
#include "mc.glsl"
layout(std430, binding = NFD_B_NEAR_MASKS) writeonly buffer NearMasks { uint near_masks[]; };
#endif
#ifdef NFD_MC_CASES
#include "mc_classify.glsl"
#define REFINES (push.child_level > 0u)
#else
#define REFINES true
#endif

void main() {
    uint k = global_invocation_index(gl_WorkGroupSize.x);
    if (k >= item_count()) return;
    uint r = push.parent_cells;
    uvec3 p = cell_coords(kept_cells[k], r);
    float grid[27];
    uint around = load_child_grid(p, k, r, grid);
#ifdef NFD_NEAR_MASKS
    uint near = 0u;
#endif
    for (uint child = 0u; child < 8u; ++child) {
        uvec3 d = corner_offset(child);
        if (!child_cell_exists(2u * p + d)) continue;
        float v[8];
        for (uint c = 0u; c < 8u; ++c) v[c] = grid[local_index(d + corner_offset(c))];
        if (REFINES && may_contain_surface(v, push.threshold)) {
            uint ci = cell_index(2u * p + d, push.child_cells);
            atomicOr(child_bits[ci >> 5], 1u << (ci & 31u));
        }
#ifdef NFD_NEAR_MASKS
        if (udf_cell_is_near(v, push.edge_limit)) near |= 1u << child;
#endif
    }
#ifdef NFD_NEAR_MASKS
    near_masks[k] = near;
#endif
#ifdef NFD_MC_CASES
    classify_parent(k, p, around, grid);
#endif
}
