#version 450
// Two-sided Lambert with an ambient floor (UDF meshes are open and not globally oriented, so the
// back of a face is lit like its front), or the normal as a colour.
layout(location = 0) in vec3 in_normal;

layout(push_constant) uniform Push {
    mat4 mvp;
    vec4 light_dir;
    vec4 tint;
} push;

layout(location = 0) out vec4 out_color;

void main() {
    vec3 n = normalize(in_normal);
    if (push.tint.w > 0.5) {
        out_color = vec4(0.5 * n + 0.5, 1.0);
        return;
    }
    float diffuse = abs(dot(n, normalize(push.light_dir.xyz)));
    out_color = vec4(push.tint.rgb * (0.3 + 0.7 * diffuse), 1.0);
}
