// Refinement, step 2: the unit-frame positions of the points of a point list (extract.glsl) in
// the chunk of NFD_POINT_CHUNK from push.list_first on, which field_eval.comp then evaluates. One
// parent per invocation, its points in ascending local order (the list's): a point per
// invocation had to find its parent by a binary search over the offsets, a load per step.
#version 450
#extension GL_GOOGLE_include_directive : require
#include "common.glsl"
#include "extract.glsl"
layout(std430, binding = NFD_B_POINTS) writeonly buffer Points { float points[]; };

void main() {
    uint k = global_invocation_index(gl_WorkGroupSize.x);
    if (k >= item_count()) return;
    uint mask = owned[k];
    uint i = offsets[k], end = push.list_first + min(NFD_POINT_CHUNK, ~push.list_first);
    if (mask == 0u || i >= end || i + uint(bitCount(mask)) <= push.list_first) return;
    uvec3 base = 2u * cell_coords(kept_cells[k], push.parent_cells);
    for (; mask != 0u; mask &= mask - 1u, ++i) {
        if (i < push.list_first || i >= end) continue;
        uint l = uint(findLSB(mask));
        vec3 u = child_point(base + uvec3(l % 3u, (l / 3u) % 3u, l / 9u));
        uint j = i - push.list_first;
        points[3u * j] = u.x;
        points[3u * j + 1u] = u.y;
        points[3u * j + 2u] = u.z;
    }
}
