// The workgroup counts of an indirect dispatch (VkDispatchIndirectCommand at record push.record)
// from the item count in a counter (counters.glsl's counted_items), folded into 2D as the host
// folds direct dispatches (common.glsl): what lets a level's kernels run on counts that no host
// has read.
#version 450
#extension GL_GOOGLE_include_directive : require
#include "bindings.h"
#define COUNTERS_BINDING NFD_B_SCAN_COUNTERS
#include "counters.glsl"
layout(local_size_x = 1) in;
layout(std430, binding = NFD_B_ARGS) writeonly buffer Args { uint args[]; };
layout(push_constant) uniform ArgsPush {
    uint capacity, slot, first;
    uint items_per_group;  // invocations per workgroup times items per invocation
    uint record;
} push;

const uint MAX_GROUPS_X = 65535u;  // Vulkan's minimum maxComputeWorkGroupCount[0]

void main() {
    uint items = counted_items(push.capacity, push.slot, push.first);
    uint groups = items / push.items_per_group + (items % push.items_per_group != 0u ? 1u : 0u);
    uint x = min(groups, MAX_GROUPS_X);
    args[3u * push.record] = x;
    args[3u * push.record + 1u] = x == 0u ? 1u : groups / x + (groups % x != 0u ? 1u : 0u);
    args[3u * push.record + 2u] = 1u;
}
