// Refinement, step 1: for each kept parent, which of the new points of its child grid it owns
// (extract.glsl); the host prefix-sums the masks' popcounts into `offsets`.
#version 450
#extension GL_GOOGLE_include_directive : require
#include "common.glsl"
#include "extract.glsl"

void main() {
    uint k = global_invocation_index(gl_WorkGroupSize.x);
    if (k >= item_count()) return;
    uint r = push.parent_cells;
    uvec3 p = cell_coords(kept_cells[k], r);
    uint around = kept_arounds[k];
    uint mask = 0u;
    [[dont_unroll]] for (uint l = 0u; l < 27u; ++l) {
        uvec3 lv = uvec3(l % 3u, (l / 3u) % 3u, l / 9u);
        uvec3 v = 2u * p + lv;
        if (!is_corner(lv) && child_point_exists(v) &&
            all(equal(owner_around(around, lv, 3u), uvec3(1u))))
            mask |= 1u << l;
    }
    owned[k] = mask;
}
