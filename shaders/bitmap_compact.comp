// The sorted list of kept cells from a level's bitmap and the prefix sum of its word popcounts;
// nothing once a total overflowed (counters.glsl): the list is sized by the level's capacity.
#version 450
#extension GL_GOOGLE_include_directive : require
#include "common.glsl"
#include "bindings.h"
#define COUNTERS_BINDING NFD_B_SCAN_COUNTERS
#include "counters.glsl"
layout(local_size_x = NFD_LOCAL_SIZE) in;
layout(std430, binding = NFD_B_KEPT_BITS) readonly buffer Bits { uint bits[]; };
layout(std430, binding = NFD_B_KEPT_PREFIX) readonly buffer Prefix { uint prefix[]; };
layout(std430, binding = NFD_B_KEPT_CELLS) writeonly buffer Cells { uint cells[]; };
layout(push_constant) uniform Push { uint words; } push;

void main() {
    uint w = global_invocation_index(gl_WorkGroupSize.x);
    if (w >= counted_items(push.words, NFD_NO_COUNTER, 0u)) return;
    uint word = bits[w];
    uint slot = prefix[w];
    while (word != 0u) {
        cells[slot++] = 32u * w + uint(findLSB(word));
        word &= word - 1u;
    }
}
