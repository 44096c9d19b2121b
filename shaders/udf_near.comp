// UDF, step 1 (udf.glsl): per parent, which of its existing children are near cells: all corners
// finite and valid edges (f_a + f_b <= push.edge_limit, step 5) that include the three edges of
// some triangle of the table (grid.h, udf_cell_is_near).
// With NFD_PREDICTED_VALUES the level's new values are in two lists (udf_predict.comp). After
// surface following (udf_flood.comp) the flood's faces mode has found the near cells instead.
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
        float f[8];
        [[unroll]] for (uint c = 0u; c < 8u; ++c) f[c] = grid[local_index(d + corner_offset(c))];
        if (udf_cell_is_near(f, push.edge_limit)) mask |= 1u << child;
    }
    near_masks[k] = mask;
}
