// UDF, step 1 (udf.glsl): per parent, which of its existing children are near cells: all corners
// finite and the smallest at most push.threshold (grid.h, udf_cell_is_near).
#version 450
#extension GL_GOOGLE_include_directive : require
#include "common.glsl"
#include "extract.glsl"
#include "mc.glsl"
#include "udf.glsl"

void main() {
    uint k = global_invocation_index(gl_WorkGroupSize.x);
    if (k >= item_count()) return;
    uint r = push.parent_cells;
    uvec3 p = cell_coords(kept_cells[k], r);
    load_grid(p, k, r);
    uint mask = 0u;
    for (uint child = 0u; child < 8u; ++child) {
        uvec3 d = corner_offset(child);
        if (!child_cell_exists(2u * p + d)) continue;
        bool finite = true, near = false;
        for (uint c = 0u; c < 8u; ++c) {
            float f = grid[local_index(d + corner_offset(c))];
            finite = finite && !isnan(f) && !isinf(f);
            near = near || f <= push.threshold;
        }
        if (finite && near) mask |= 1u << child;
    }
    near_masks[k] = mask;
}
