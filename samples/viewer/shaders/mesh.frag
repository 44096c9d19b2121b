#version 450
// Two-sided Lambert with an ambient floor (UDF meshes are open and not globally oriented, so the
// back of a face is lit like its front) of the tint or of the vertex colours, or the normal as a
// colour. The colours are written unconverted to the UNORM target: libnfdecode's colours are the
// input's display-encoded values (nfdecode.h, "Colour"), shown as the input showed them.
layout(location = 0) in vec3 in_normal;
layout(location = 1) in vec3 in_colour;

layout(push_constant) uniform Push {
    mat4 mvp;
    vec4 light_dir;
    vec4 tint;
} push;

layout(location = 0) out vec4 out_color;

void main() {
    vec3 n = normalize(in_normal);
    if (push.tint.w > 0.5 && push.tint.w < 1.5) {
        out_color = vec4(0.5 * n + 0.5, 1.0);
        return;
    }
    float diffuse = abs(dot(n, normalize(push.light_dir.xyz)));
    vec3 albedo = push.tint.w > 1.5 ? in_colour : push.tint.rgb;
    out_color = vec4(albedo * (0.3 + 0.7 * diffuse), 1.0);
}
