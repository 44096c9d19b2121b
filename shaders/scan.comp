// Exclusive prefix sum, in blocks of 1024 elements (256 invocations x 4): each block is scanned
// in shared memory and its total written to `sums`; the host scans `sums` the same way and
// dispatches the ADD_BLOCK_OFFSETS variant to add them back. POPCOUNT scans the number of set
// bits of each word (a kept-cell bitmap) instead of the words themselves.
#version 450
#extension GL_GOOGLE_include_directive : require
#include "common.glsl"
layout(local_size_x = 256) in;
layout(constant_id = 0) const bool POPCOUNT = false;
layout(std430, binding = 0) readonly buffer Input { uint data_in[]; };
layout(std430, binding = 1) buffer Output { uint data_out[]; };
layout(std430, binding = 2) buffer Sums { uint sums[]; };
layout(push_constant) uniform Push { uint count; } push;

shared uint partial[256];

void main() {
    uint group = gl_WorkGroupID.x + gl_WorkGroupID.y * gl_NumWorkGroups.x;
    if (group * 1024u >= push.count) return;  // excess groups of a 2D-folded dispatch
    uint base = group * 1024u + gl_LocalInvocationIndex * 4u;
#ifdef ADD_BLOCK_OFFSETS
    uint add = sums[group];
    for (uint i = 0u; i < 4u; ++i)
        if (base + i < push.count) data_out[base + i] += add;
#else
    uint local_prefix[4];
    uint total = 0u;
    for (uint i = 0u; i < 4u; ++i) {
        uint x = base + i < push.count ? data_in[base + i] : 0u;
        local_prefix[i] = total;
        total += POPCOUNT ? uint(bitCount(x)) : x;
    }
    uint t = gl_LocalInvocationIndex;
    partial[t] = total;
    barrier();
    for (uint step = 1u; step < 256u; step <<= 1) {  // Hillis-Steele inclusive scan
        uint other = t >= step ? partial[t - step] : 0u;
        barrier();
        partial[t] += other;
        barrier();
    }
    uint before = partial[t] - total;
    for (uint i = 0u; i < 4u; ++i)
        if (base + i < push.count) data_out[base + i] = before + local_prefix[i];
    if (t == 255u) sums[group] = partial[255];
#endif
}
