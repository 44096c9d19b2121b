// A recording's VkDrawIndexedIndirectCommand (nfd_device_mesh.draw): the mesh's triangles as
// counter push.triangle_slot holds them, none after an overflow, so that a host draws the
// decoded mesh without reading a count back.
#version 450
#extension GL_GOOGLE_include_directive : require
#include "bindings.h"
#define COUNTERS_BINDING NFD_B_SCAN_COUNTERS
#include "counters.glsl"
layout(local_size_x = 1) in;
layout(std430, binding = NFD_B_ARGS) writeonly buffer Draw { uint draw[]; };
layout(push_constant) uniform DrawPush { uint triangle_slot, triangle_capacity; } push;

void main() {
    draw[0] = 3u * counted_items(push.triangle_capacity, push.triangle_slot, 0u);  // indexCount
    draw[1] = 1u;                                                                 // instanceCount
    draw[2] = 0u;                                                                 // firstIndex
    draw[3] = 0u;                                                                 // vertexOffset
    draw[4] = 0u;                                                                 // firstInstance
}
