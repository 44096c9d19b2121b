// Refinement, step 4: the corner values of each newly kept cell, in the order of the sorted kept
// list, read from its parent's child grid (the parent level's bindings of extract.glsl).
#version 450
#extension GL_GOOGLE_include_directive : require
#include "common.glsl"
#include "extract.glsl"
layout(std430, binding = NFD_B_CHILD_CELLS) readonly buffer ChildCells { uint child_cells[]; };
layout(std430, binding = NFD_B_CHILD_CORNERS) writeonly buffer ChildCorners {
    float child_corners[];
};

void main() {
    uint j = global_invocation_index(gl_WorkGroupSize.x);
    if (j >= item_count()) return;
    uint r = push.parent_cells;
    uvec3 child = cell_coords(child_cells[j], push.child_cells);
    uvec3 p = child / 2u;
    uint k = kept_rank(cell_index(p, r));
    uint around = kept_arounds[k];
    uvec3 d = child - 2u * p;
    for (uint c = 0u; c < 8u; ++c)
        child_corners[8u * j + c] = child_grid_value(p, k, around, d + corner_offset(c), r);
}
