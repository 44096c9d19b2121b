// Refinement, step 2: the unit-frame positions of the points of a point list (extract.glsl) from
// push.first on, push.count of them at most (a chunk of the list that field_eval.comp then
// evaluates; the total is in counter push.count_slot). One point per invocation: its owner is the
// last parent whose offset is at most the point's index (a binary search over the offsets, which
// are non-decreasing over the whole buffer: parents past the last one own no points), and it is
// that parent's (index - offset)-th owned point in ascending local order, the order
// child_grid_value() assumes.
#version 450
#extension GL_GOOGLE_include_directive : require
#include "common.glsl"
#include "extract.glsl"
layout(std430, binding = NFD_B_POINTS) writeonly buffer Points { float points[]; };

void main() {
    uint j = global_invocation_index(gl_WorkGroupSize.x);
    if (j >= item_count()) return;
    uint i = push.first + j;
    uint lo = 0u, hi = uint(offsets.length());  // offsets[lo] <= i < offsets[hi] (or hi = end)
    while (hi - lo > 1u) {
        uint mid = (lo + hi) / 2u;
        if (offsets[mid] <= i) lo = mid;
        else hi = mid;
    }
    uint mask = owned[lo];
    for (uint skip = i - offsets[lo]; skip > 0u; --skip) mask &= mask - 1u;
    uint l = uint(findLSB(mask));
    uvec3 p = cell_coords(kept_cells[lo], push.parent_cells);
    vec3 u = child_point(2u * p + uvec3(l % 3u, (l / 3u) % 3u, l / 9u));
    points[3u * j] = u.x;
    points[3u * j + 1u] = u.y;
    points[3u * j + 2u] = u.z;
}
