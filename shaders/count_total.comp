// The total of a prefix-summed list into a counter (counters.glsl): the exclusive prefix at its
// last element plus that element (POPCOUNT: its set bits), the item count of the kernels that
// follow; and the overflow flag when it exceeds the capacity their buffers were sized for. The
// lists are sized by capacity and zero past their items, so `last` is known when recording.
#version 450
#extension GL_GOOGLE_include_directive : require
#include "bindings.h"
#define COUNTERS_BINDING NFD_B_SCAN_COUNTERS
#include "counters.glsl"
layout(local_size_x = 1) in;
layout(constant_id = 0) const bool POPCOUNT = false;
layout(std430, binding = NFD_B_SCAN_IN) readonly buffer Input { uint data_in[]; };
layout(std430, binding = NFD_B_SCAN_OUT) readonly buffer Prefix { uint prefix[]; };
layout(push_constant) uniform TotalPush { uint last, slot, capacity, unused; } push;

void main() {
    uint x = data_in[push.last];
    uint total = prefix[push.last] + (POPCOUNT ? uint(bitCount(x)) : x);
    counters[push.slot] = total;
    if (total > push.capacity) counters[NFD_COUNTER_OVERFLOW] = 1u;
}
