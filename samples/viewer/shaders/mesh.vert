#version 450
// The viewer's mesh vertex shader: positions in the asset's original frame, the model matrix
// maps them into the grid (scene.h). The model is a uniform scale plus a translation, so normals
// need no inverse-transpose.
layout(location = 0) in vec3 in_position;
layout(location = 1) in vec3 in_normal;
layout(location = 2) in vec3 in_colour;  // meaningful in mode 2 only (MeshPipeline::draw)

layout(push_constant) uniform Push {
    mat4 mvp;
    vec4 light_dir;  // xyz: towards the light, world frame
    vec4 tint;       // rgb: the asset's colour; w: mode (0 lit tint, 1 normals, 2 lit colours)
} push;

layout(location = 0) out vec3 out_normal;
layout(location = 1) out vec3 out_colour;

void main() {
    out_normal = in_normal;
    out_colour = in_colour;
    gl_Position = push.mvp * vec4(in_position, 1.0);
}
