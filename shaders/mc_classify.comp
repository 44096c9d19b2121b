// SDF marching cubes, step 1 (mc_classify.glsl) on the finest level: per parent, its child grid
// read, then classified.
#version 450
#extension GL_GOOGLE_include_directive : require
#include "common.glsl"
#include "extract.glsl"
#include "mc_classify.glsl"

void main() {
    uint k = global_invocation_index(gl_WorkGroupSize.x);
    if (k >= item_count()) return;
    uvec3 p = cell_coords(kept_cells[k], push.parent_cells);
    uint around = load_grid(p, k, push.parent_cells);
    classify_parent(k, p, around, grid);
}
