// The sorted list of kept cells from a level's bitmap and the prefix sum of its word popcounts.
#version 450
#extension GL_GOOGLE_include_directive : require
#include "common.glsl"
layout(local_size_x = 64) in;
layout(std430, binding = 0) readonly buffer Bits { uint bits[]; };
layout(std430, binding = 1) readonly buffer Prefix { uint prefix[]; };
layout(std430, binding = 2) writeonly buffer Cells { uint cells[]; };
layout(push_constant) uniform Push { uint words; } push;

void main() {
    uint w = global_invocation_index(64);
    if (w >= push.words) return;
    uint word = bits[w];
    uint slot = prefix[w];
    while (word != 0u) {
        cells[slot++] = 32u * w + uint(findLSB(word));
        word &= word - 1u;
    }
}
