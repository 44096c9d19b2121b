// UDF, the gradient list (udf.glsl): per parent, which of its 27 child-grid points it owns and are
// a corner of a near cell (of any parent: the up to 8 finest cells around the point). The host
// prefix-sums the masks' popcounts, refine_points.comp writes the points, field_eval.comp
// (WITH_GRADIENT) evaluates them. Points another list has are copied instead (udf_gradient_merge),
// and NFD_B_OWNED then receives the mask of the points to evaluate: with a counter in
// push.tally_slot (progressive levels) the corners of the parent that the level above listed
// (NFD_B_CORNER_GRADIENTS), whose number it adds there (a progressive level's gradient count is
// the list's size less those, on every path); compiled with NFD_PREDICTED_VALUES, the points of
// the meshed level's predicted list (udf_predict.comp), whose owners are the same.
#version 450
#extension GL_GOOGLE_include_directive : require
#include "common.glsl"
#include "extract.glsl"
#include "mc.glsl"
#include "udf.glsl"
layout(std430, binding = NFD_B_CORNER_GRADIENTS) readonly buffer CornerGradients {
    uint corner_gradients[];
};

// v | v >> s of a 64-bit mask held as (low, high) words, 0 < s < 32.
uvec2 shift_or(uvec2 v, uint s) {
    return v | uvec2((v.x >> s) | (v.y << (32u - s)), v.y >> s);
}

void main() {
    uint k = global_invocation_index(gl_WorkGroupSize.x);
    if (k >= item_count()) return;
    bool carried_above = push.tally_slot != NFD_NO_COUNTER;
    uint r = push.parent_cells;
    uvec3 p = cell_coords(kept_cells[k], r);
    uint around = kept_arounds[k];
    // The near cells among the 4x4x4 finest cells 2p - 1 + b (b in 0..3 per axis) around p's
    // children, from the near masks of the kept cells around p: bit b.x + 4 b.y + 16 b.z.
    uvec2 near = uvec2(0u);
    for (uint n = 0u; n < 27u; ++n) {
        if ((around & (1u << n)) == 0u) continue;
        uvec3 offset = uvec3(n % 3u, (n / 3u) % 3u, n / 9u);  // neighbour p + offset - 1
        uint children = near_masks[n == 13u ? k : kept_rank(cell_index(p + offset - 1u, r))];
        for (uint child = 0u; child < 8u; ++child) {
            ivec3 b = 2 * ivec3(offset) + ivec3(corner_offset(child)) - 1;
            if ((children & (1u << child)) == 0u || any(lessThan(b, ivec3(0))) ||
                any(greaterThan(b, ivec3(3))))
                continue;
            uint bit = uint(b.x + 4 * b.y + 16 * b.z);
            if (bit < 32u) near.x |= 1u << bit;
            else near.y |= 1u << (bit - 32u);
        }
    }
    // Point `local` is a corner of the finest cells b = local + {0, 1} per axis: the near bits
    // dilated toward lower b along x, y and z (bits past b = 2 are polluted by the shifts and
    // never read).
    near = shift_or(near, 1u);
    near = shift_or(near, 4u);
    near = shift_or(near, 16u);
    uint mask = 0u, fresh = 0u, carried_points = 0u;
#ifdef NFD_PREDICTED_VALUES
    uint copied = predicted_owned[k];
    bool copies = true;
#else
    uint copied = 0u;
    bool copies = carried_above;
#endif
    [[dont_unroll]] for (uint l = 0u; l < 27u; ++l) {
        uvec3 local = uvec3(l % 3u, (l / 3u) % 3u, l / 9u);
        if (!child_point_exists(2u * p + local) ||
            any(notEqual(owner_around(around, local, 3u), uvec3(1u))))
            continue;
        uint bit = local.x + 4u * local.y + 16u * local.z;
        if (((bit < 32u ? near.x >> bit : near.y >> (bit - 32u)) & 1u) == 0u) continue;
        mask |= 1u << l;
        bool carried = carried_above && is_corner(local) &&
                       corner_gradients[8u * k + corner_index(local)] != NFD_NOT_LISTED;
        if (carried) ++carried_points;
        else if ((copied & (1u << l)) == 0u) fresh |= 1u << l;
    }
    if (carried_points != 0u) atomicAdd(counters[push.tally_slot], carried_points);
    gradient_owned[k] = mask;
    if (copies) owned[k] = fresh;
}
