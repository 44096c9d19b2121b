// The UDF mesher of extract.h (steps 1-7) on the GPU, shared by udf_*.comp; the CPU twin is
// mesh_udf_cpu.cpp. The parents and child grids are mc.glsl's. Per parent, `near_masks` says
// which of its children are near cells (step 1). The gradients are evaluated once per child-grid
// point that is a corner of a near cell, by the point's owner (the kept parent with the smallest
// index whose closed box contains it, extract.glsl's owner_around, now over all 27 points of a
// child grid, corners included); the list has the layout of extract.glsl's new values (a 27-bit
// mask and an offset per parent), and field_eval.comp's WITH_GRADIENT output per point: (value, gradient),
// the value bit-identical to field_eval's. Everything after udf_gradient_count reads the values
// from there too, so the level's sparse storage is released once the list is made.
#ifndef NFD_UDF_GLSL
#define NFD_UDF_GLSL

layout(std430, binding = NFD_B_NEAR_MASKS) buffer NearMasks { uint near_masks[]; };
layout(std430, binding = NFD_B_GRADIENT_OWNED) buffer GradientOwned { uint gradient_owned[]; };
layout(std430, binding = NFD_B_GRADIENT_OFFSETS) readonly buffer GradientOffsets {
    uint gradient_offsets[];
};
#ifndef UDF_GRADIENTS_WRITTEN
layout(std430, binding = NFD_B_GRADIENTS) readonly buffer Gradients { vec4 gradients[]; };
#endif

// The index in the gradient list of child-grid point w, owned by kept parent o (rank ko), or
// NFD_NOT_LISTED.
uint listed_gradient(uvec3 w, uvec3 o, uint ko) {
    uint bit = 1u << local_index(w - 2u * o);
    if ((gradient_owned[ko] & bit) == 0u) return NFD_NOT_LISTED;
    return gradient_offsets[ko] + bitCount(gradient_owned[ko] & (bit - 1u));
}
// The index in the gradient list of point l of kept parent p's (rank k) child grid (around: its
// kept_arounds bits), or NFD_NOT_LISTED.
uint gradient_index(uvec3 p, uint k, uint around, uvec3 l, uint r) {
    uint ko;
    uvec3 o = local_owner(p, k, around, l, 3u, r, ko);
    return listed_gradient(2u * p + l, o, ko);
}
// (value, gradient) at point l of kept parent p's child grid, a corner of a near cell (so its
// owner listed it).
vec4 field_at(uvec3 p, uint k, uint around, uvec3 l, uint r) {
    return gradients[gradient_index(p, k, around, l, r)];
}

// As mesh_udf_cpu.cpp: left to right, no fused multiply-add, so that equal gradients give equal
// pseudo-signs on both paths.
float dot3(vec3 a, vec3 b) {
    precise float d = a.x * b.x + a.y * b.y + a.z * b.z;
    return d;
}

// Step 2's canonical direction: the largest-magnitude component (lowest axis on ties) positive.
// False when the vector is zero or not finite.
bool canonical_direction(vec3 v, out vec3 n) {
    uint major = 0u;
    if (abs(v.y) > abs(v[major])) major = 1u;
    if (abs(v.z) > abs(v[major])) major = 2u;
    n = v[major] > 0.0 ? v : -v;
    return !any(isnan(v)) && !any(isinf(v)) && v[major] != 0.0;
}

#endif
