// Refinement, step 2: each kept parent writes the unit-frame positions of the child-grid points
// it owns to the compact list that field_eval.comp evaluates.
#version 450
#extension GL_GOOGLE_include_directive : require
#include "common.glsl"
#include "extract.glsl"
layout(std430, binding = NFD_B_POINTS) writeonly buffer Points { float points[]; };

void main() {
    uint k = global_invocation_index(gl_WorkGroupSize.x);
    if (k >= push.count) return;
    uvec3 p = cell_coords(kept_cells[k], push.parent_cells);
    uint mask = owned[k];
    uint slot = offsets[k];
    while (mask != 0u) {  // ascending local index: the order child_grid_value() assumes
        uint l = uint(findLSB(mask));
        mask &= mask - 1u;
        vec3 u = child_point(2u * p + uvec3(l % 3u, (l / 3u) % 3u, l / 9u));
        points[3u * slot] = u.x;
        points[3u * slot + 1u] = u.y;
        points[3u * slot + 2u] = u.z;
        ++slot;
    }
}
