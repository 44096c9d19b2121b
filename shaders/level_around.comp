// Per kept cell of a level, which of its 27 neighbours are kept (extract.glsl's kept_around),
// once per level: the refinement and mesher kernels that find owners on these bits read one word
// per cell instead of the bitmap words of nine rows each (on llvmpipe every load is an 8-lane
// gather).
#version 450
#extension GL_GOOGLE_include_directive : require
#include "common.glsl"
#include "bindings.h"
layout(std430, binding = NFD_B_KEPT_AROUND) buffer KeptAround { uint kept_arounds[]; };
#define NFD_KEPT_AROUND_WRITTEN
#include "extract.glsl"

void main() {
    uint k = global_invocation_index(gl_WorkGroupSize.x);
    if (k >= item_count()) return;
    uint r = push.parent_cells;
    kept_arounds[k] = kept_around(cell_coords(kept_cells[k], r), r);
}
