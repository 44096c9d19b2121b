// Refinement, step 4: the corner values of each newly kept cell, in the order of the sorted kept
// list, read from its parent's child grid (the parent level's bindings of extract.glsl).
//
// Defining NFD_CORNER_GRADIENTS gives the variant for progressive UDF levels, which also writes
// where each corner is in this level's gradient list, or NFD_NOT_LISTED (udf.glsl): the next
// level's mesher copies those gradients instead of evaluating them again, as grid.cpp's
// evaluate_udf_gradients does on the CPU. Both lists are found through the same owner.
#version 450
#extension GL_GOOGLE_include_directive : require
#include "common.glsl"
#include "extract.glsl"
#ifdef NFD_CORNER_GRADIENTS
#include "udf.glsl"
layout(std430, binding = NFD_B_CORNER_GRADIENTS) writeonly buffer CornerGradients {
    uint corner_gradients[];
};
#endif
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
    for (uint c = 0u; c < 8u; ++c) {
        uvec3 l = d + corner_offset(c);
#ifdef NFD_CORNER_GRADIENTS
        uint ko;
        uvec3 o = local_owner(p, k, around, l, 3u, r, ko);
        child_corners[8u * j + c] =
            is_corner(l) ? corners[8u * k + corner_index(l)] : owned_value(2u * p + l, o, ko);
        corner_gradients[8u * j + c] = listed_gradient(2u * p + l, o, ko);
#else
        child_corners[8u * j + c] = child_grid_value(p, k, around, l, r);
#endif
    }
}
