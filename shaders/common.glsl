// Shared by all nfdecode compute shaders: dispatch indexing, accurate sine/cosine, the positional
// encoding of FORMAT.md ("Evaluation") and the unit-frame grid of extract.h.
#ifndef NFD_COMMON_GLSL
#define NFD_COMMON_GLSL

// Large launches are split over gl_NumWorkGroups.y because maxComputeWorkGroupCount[0] may be
// as small as 65535; the host dispatches ceil(n / local size) groups folded into 2D.
// Callers pass gl_WorkGroupSize.x: GLSL defines it only after the local size is declared.
uint global_invocation_index(uint local_size) {
    uint group = gl_WorkGroupID.x + gl_WorkGroupID.y * gl_NumWorkGroups.x;
    return group * local_size + gl_LocalInvocationIndex;
}

// sin and cos accurate to ~1 ulp for |x| < 8192, independent of the driver. Vulkan only requires
// 2^-11 absolute error from the built-in sin/cos, and only on [-pi, pi]; SIREN's first layer
// (omega0 = 30) and the top encoding frequencies (~489 rad) reach arguments of several hundred.
// Cody-Waite reduction by pi/2: the split constants carry few enough mantissa bits that
// j * PIO2_A and j * PIO2_B are exact for |j| < 2^15, so the reduction adds no rounding error
// beyond the last term. Then Cephes' sinf/cosf minimax polynomials on [-pi/4, pi/4].
const float TWO_OVER_PI = 0.636619772367581343;
const float PIO2_A = 1.5703125;                 // pi/2 rounded to 8 bits
const float PIO2_B = 4.837512969970703125e-4;   // next 12 bits
const float PIO2_C = 7.54978995489188216e-8;    // the rest

// Returns (sin x, cos x).
vec2 sincos_reduced(float x) {
    precise float j = round(x * TWO_OVER_PI);
    precise float r = ((x - j * PIO2_A) - j * PIO2_B) - j * PIO2_C;
    float z = r * r;
    float s = r + r * z * ((-1.9515295891e-4 * z + 8.3321608736e-3) * z - 1.6666654611e-1);
    float c = 1.0 - 0.5 * z + z * z * ((2.443315711809948e-5 * z - 1.388731625493765e-3) * z
                                       + 4.166664568298827e-2);
    // sin(r + q pi/2) for quadrant q = j mod 4 (two's complement & 3 is a true modulo).
    int q = int(j) & 3;
    vec2 sc = (q & 1) != 0 ? vec2(c, -s) : vec2(s, c);
    return (q & 2) != 0 ? -sc : sc;
}
float sin_reduced(float x) { return sincos_reduced(x).x; }
vec4 sin_reduced(vec4 x) {
    return vec4(sin_reduced(x.x), sin_reduced(x.y), sin_reduced(x.z), sin_reduced(x.w));
}

// Unit-frame coordinate of fine grid vertex i (extract.h): -1 + i * step with step = 2 / resolution
// rounded to f32, computed exactly as the CPU reference does (no fused multiply-add).
float fine_coordinate(uint i, float step) {
    precise float u = -1.0 + float(i) * step;
    return u;
}

#endif
