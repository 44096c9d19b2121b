// UDF, the gradient list (udf.glsl): per parent, which of its 27 child-grid points it owns and are
// a corner of a near cell (of any parent: the up to 8 finest cells around the point). The host
// prefix-sums the masks' popcounts, refine_points.comp writes the points, field_eval.comp
// (WITH_GRADIENT) evaluates them. With CARRIED (progressive levels), the corners of the parent
// that the level above listed (NFD_B_CORNER_GRADIENTS) are copied instead (udf_gradient_merge):
// NFD_B_OWNED then receives the mask of the points to evaluate.
#version 450
#extension GL_GOOGLE_include_directive : require
#include "common.glsl"
#include "extract.glsl"
#include "mc.glsl"
#include "udf.glsl"
layout(constant_id = 0) const bool CARRIED = false;
layout(std430, binding = NFD_B_CORNER_GRADIENTS) readonly buffer CornerGradients {
    uint corner_gradients[];
};

void main() {
    uint k = global_invocation_index(gl_WorkGroupSize.x);
    if (k >= item_count()) return;
    uint r = push.parent_cells;
    uvec3 p = cell_coords(kept_cells[k], r);
    uint mask = 0u, fresh = 0u;
    for (uint l = 0u; l < 27u; ++l) {
        uvec3 local = uvec3(l % 3u, (l / 3u) % 3u, l / 9u);
        uvec3 w = 2u * p + local;
        if (!child_point_exists(w) || any(notEqual(owner_cell(w, 2u, r), p))) continue;
        bool needed = false;
        for (uint c = 0u; c < 8u && !needed; ++c)
            needed = is_near_cell(ivec3(w) - ivec3(corner_offset(c)), r);
        if (!needed) continue;
        mask |= 1u << l;
        if (!CARRIED || !is_corner(local) ||
            corner_gradients[8u * k + corner_index(local)] == NFD_NOT_LISTED)
            fresh |= 1u << l;
    }
    gradient_owned[k] = mask;
    if (CARRIED) owned[k] = fresh;
}
