// Vertex normals: the normalised central-difference gradient of the field from the six samples
// field_eval.comp took around each vertex (+x, -x, +y, -y, +z, -z); f > 0 outside, so it points
// out. Where it vanishes (or overflows), the vertex's edge direction from inside to outside.
#version 450
#extension GL_GOOGLE_include_directive : require
#include "common.glsl"
layout(local_size_x = 64) in;
layout(std430, binding = 0) readonly buffer Values { float values[]; };
layout(std430, binding = 1) readonly buffer VertexEdges { uint vertex_edges[]; };
layout(std430, binding = 2) writeonly buffer Normals { float normals[]; };
layout(push_constant) uniform Push { uint count; } push;

void main() {
    uint i = global_invocation_index(64);
    if (i >= push.count) return;
    vec3 g = vec3(values[6u * i] - values[6u * i + 1u], values[6u * i + 2u] - values[6u * i + 3u],
                  values[6u * i + 4u] - values[6u * i + 5u]);
    float len = sqrt(g.x * g.x + g.y * g.y + g.z * g.z);
    vec3 n;
    if (len > 0.0 && !isinf(len) && !isnan(len)) {
        n = g / len;
    } else {
        uint edge = vertex_edges[i];
        n = vec3(0.0);
        n[edge & 3u] = (edge & 4u) != 0u ? 1.0 : -1.0;
    }
    normals[3u * i] = n.x;
    normals[3u * i + 1u] = n.y;
    normals[3u * i + 2u] = n.z;
}
