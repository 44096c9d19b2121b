// Exclusive prefix sum, in blocks of NFD_SCAN_BLOCK elements (1024: 256 invocations x 4): each
// block is scanned in shared memory and its total written to `sums`; the host scans `sums` the
// same way and dispatches the ADD_BLOCK_OFFSETS variant to add them back. POPCOUNT scans the
// number of set bits of each word (a kept-cell bitmap, edge masks) instead of the words themselves.
#version 450
#extension GL_GOOGLE_include_directive : require
#include "common.glsl"
#include "bindings.h"
layout(local_size_x = NFD_SCAN_LOCAL_SIZE) in;
layout(constant_id = 0) const bool POPCOUNT = false;
layout(std430, binding = NFD_B_SCAN_IN) readonly buffer Input { uint data_in[]; };
layout(std430, binding = NFD_B_SCAN_OUT) buffer Output { uint data_out[]; };
layout(std430, binding = NFD_B_SCAN_SUMS) buffer Sums { uint sums[]; };
layout(push_constant) uniform Push { uint count; } push;

shared uint partial[NFD_SCAN_LOCAL_SIZE];
const uint PER_INVOCATION = NFD_SCAN_BLOCK / NFD_SCAN_LOCAL_SIZE;

void main() {
    uint group = gl_WorkGroupID.x + gl_WorkGroupID.y * gl_NumWorkGroups.x;
    if (group * NFD_SCAN_BLOCK >= push.count) return;  // excess groups of a 2D-folded dispatch
    uint base = group * NFD_SCAN_BLOCK + gl_LocalInvocationIndex * PER_INVOCATION;
#ifdef ADD_BLOCK_OFFSETS
    uint add = sums[group];
    for (uint i = 0u; i < PER_INVOCATION; ++i)
        if (base + i < push.count) data_out[base + i] += add;
#else
    uint local_prefix[PER_INVOCATION];
    uint total = 0u;
    for (uint i = 0u; i < PER_INVOCATION; ++i) {
        uint x = base + i < push.count ? data_in[base + i] : 0u;
        local_prefix[i] = total;
        total += POPCOUNT ? uint(bitCount(x)) : x;
    }
    uint t = gl_LocalInvocationIndex;
    partial[t] = total;
    barrier();
    for (uint step = 1u; step < NFD_SCAN_LOCAL_SIZE; step <<= 1) {  // Hillis-Steele inclusive scan
        uint other = t >= step ? partial[t - step] : 0u;
        barrier();
        partial[t] += other;
        barrier();
    }
    uint before = partial[t] - total;
    for (uint i = 0u; i < PER_INVOCATION; ++i)
        if (base + i < push.count) data_out[base + i] = before + local_prefix[i];
    if (t == NFD_SCAN_LOCAL_SIZE - 1) sums[group] = partial[t];
#endif
}
