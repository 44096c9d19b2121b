// The level above the coarsest, all of its cells kept: the 8 corner values of each (in cell
// order) from the field at its vertices, evaluated densely on a side^3 grid (push.child_cells =
// side). A last cell whose children past the grid are dropped has corners nothing reads: 0.
#version 450
#extension GL_GOOGLE_include_directive : require
#include "common.glsl"
#include "extract.glsl"
layout(std430, binding = NFD_B_DENSE_VALUES) readonly buffer DenseValues { float dense[]; };
layout(std430, binding = NFD_B_CHILD_CORNERS) writeonly buffer ChildCorners {
    float child_corners[];
};

void main() {
    uint c = global_invocation_index(gl_WorkGroupSize.x);
    if (c >= item_count()) return;
    uint side = push.child_cells;
    uvec3 p = cell_coords(c, push.parent_cells);
    for (uint i = 0u; i < 8u; ++i) {
        uvec3 v = p + corner_offset(i);
        bool evaluated = all(lessThan(v, uvec3(side)));
        child_corners[8u * c + i] = evaluated ? dense[(v.z * side + v.y) * side + v.x] : 0.0;
    }
}
