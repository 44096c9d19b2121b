// Refinement, step 2: each kept parent of a chunk (push.first_parent, push.count parents) writes
// the unit-frame positions of the child-grid points it owns to the compact list that
// field_eval.comp evaluates.
#version 450
#extension GL_GOOGLE_include_directive : require
#include "common.glsl"
#include "extract.glsl"
layout(std430, binding = NFD_B_POINTS) writeonly buffer Points { float points[]; };

void main() {
    uint j = global_invocation_index(gl_WorkGroupSize.x);
    if (j >= push.count) return;
    uint k = push.first_parent + j;  // a chunk of parents: its points start at slot 0
    uvec3 p = cell_coords(kept_cells[k], push.parent_cells);
    uint mask = owned[k];
    uint slot = offsets[k] - offsets[push.first_parent];
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
