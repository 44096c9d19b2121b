// Progressive UDF levels: per newly kept cell (the next finer level's parents, in the order of
// the sorted kept list), the index of each of its 8 corners in this level's gradient list, or
// NFD_NOT_LISTED (udf.glsl, gradient_index; the parent level's bindings of extract.glsl). The next
// level's mesher copies those gradients instead of evaluating them again, as grid.cpp's
// evaluate_udf_gradients does on the CPU.
#version 450
#extension GL_GOOGLE_include_directive : require
#include "common.glsl"
#include "extract.glsl"
#include "udf.glsl"
layout(std430, binding = NFD_B_CHILD_CELLS) readonly buffer ChildCells { uint child_cells[]; };
layout(std430, binding = NFD_B_CORNER_GRADIENTS) writeonly buffer CornerGradients {
    uint corner_gradients[];
};

void main() {
    uint j = global_invocation_index(gl_WorkGroupSize.x);
    if (j >= item_count()) return;
    uint r = push.parent_cells;
    uvec3 child = cell_coords(child_cells[j], push.child_cells);
    uvec3 p = child / 2u;
    uint k = kept_rank(cell_index(p, r));
    uint around = kept_arounds[k];
    for (uint c = 0u; c < 8u; ++c)
        corner_gradients[8u * j + c] = gradient_index(p, k, around, child - 2u * p + corner_offset(c), r);
}
