// UDF, step 1 (udf.glsl): per parent, which of its existing children are near cells: all corners
// finite and valid edges (f_a + f_b <= push.edge_limit, step 5) that include the three edges of
// some triangle of the table (grid.h, udf_cell_is_near).
// With NFD_PREDICTED_VALUES the level's new values are in two lists (udf_predict.comp). After
// surface following (udf_flood.comp) the flood's faces mode has found the near cells instead.
#version 450
#extension GL_GOOGLE_include_directive : require
#extension GL_EXT_control_flow_attributes : require
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
        bool finite = true;
        [[unroll]] for (uint c = 0u; c < 8u; ++c) {  // constant indices into f: see edge_start_corner
            f[c] = grid[local_index(d + corner_offset(c))];
            finite = finite && !isnan(f[c]) && !isinf(f[c]);
        }
        uint valid = 0u;
        [[unroll]] for (uint e = 0u; e < 12u; ++e) {
            uint a = edge_start_corner(e), b = a + (1u << (e / 4u));
            precise float sum = f[a] + f[b];
            if (sum <= push.edge_limit) valid |= 1u << e;
        }
        if (finite && mc_holds_triangle(valid)) mask |= 1u << child;
    }
    near_masks[k] = mask;
}
