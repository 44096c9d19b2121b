// UDF, the gradient list (udf.glsl): per parent, which of its 27 child-grid points it owns and are
// a corner of a near cell (of any parent: the up to 8 finest cells around the point), and how
// many; the host prefix-sums the counts, refine_points.comp writes the points, field_eval.comp
// (WITH_GRADIENT) evaluates them.
#version 450
#extension GL_GOOGLE_include_directive : require
#include "common.glsl"
#include "extract.glsl"
#include "mc.glsl"
#include "udf.glsl"
layout(std430, binding = NFD_B_COUNTS) writeonly buffer Counts { uint counts[]; };

void main() {
    uint k = global_invocation_index(gl_WorkGroupSize.x);
    if (k >= item_count()) return;
    uint r = push.parent_cells;
    uvec3 p = cell_coords(kept_cells[k], r);
    uint mask = 0u;
    for (uint l = 0u; l < 27u; ++l) {
        uvec3 w = 2u * p + uvec3(l % 3u, (l / 3u) % 3u, l / 9u);
        if (!child_point_exists(w) || any(notEqual(owner_cell(w, 2u, r), p))) continue;
        bool needed = false;
        for (uint c = 0u; c < 8u && !needed; ++c)
            needed = is_near_cell(ivec3(w) - ivec3(corner_offset(c)), r);
        if (needed) mask |= 1u << l;
    }
    gradient_owned[k] = mask;
    counts[k] = bitCount(mask);
}
