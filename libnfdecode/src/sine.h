// sin and cos for the CPU evaluator: the C++ twin of common.glsl's sincos_reduced (the same
// Cody-Waite reduction by pi/2 and Cephes minimax polynomials, accurate to ~1 ulp for
// |x| < 8192), written as branch-free loops over arrays so that compilers vectorise them. The C
// library's sinf is as accurate but scalar: at width 32 it was two thirds of the evaluator's time.
#pragma once
#include <cstddef>
#include <cstdint>
#include <cstring>

namespace nfd {

namespace sine_detail {
constexpr float kTwoOverPi = 0.636619772367581343f;
constexpr float kPio2A = 1.5703125f;                // pi/2 rounded to 8 bits
constexpr float kPio2B = 4.837512969970703125e-4f;  // next 12 bits
constexpr float kPio2C = 7.54978995489188216e-8f;   // the rest
// Adding and subtracting 1.5 * 2^23 rounds a float of magnitude < 2^22 to the nearest integer
// (ties to even) with two vectorisable additions.
constexpr float kRoundMagic = 12582912.0f;

// Selection by bit masks (all ones or zero) rather than ?: so that the x86-64 baseline (SSE2, no
// blend instruction) vectorises the loops too.
inline uint32_t mask(bool condition) { return 0u - uint32_t(condition); }
inline float select(uint32_t mask, float if_set, float otherwise) {
    uint32_t a, b;
    std::memcpy(&a, &if_set, 4);
    std::memcpy(&b, &otherwise, 4);
    a = (a & mask) | (b & ~mask);
    float out;
    std::memcpy(&out, &a, 4);
    return out;
}

// The reduced argument r in [-pi/4, pi/4] and quadrant q of x = r + q pi/2.
inline void reduce(float x, float* r, int32_t* q) {
    const float j = (x * kTwoOverPi + kRoundMagic) - kRoundMagic;
    // Past the accurate range (hostile inputs only) the angle is taken as 0: a finite argument
    // still gives a number (x - x is 0), inf and NaN give NaN as the C library's sinf does. The
    // quadrant needs only j mod 4, and a j that no int holds must not reach the conversion.
    const uint32_t in_range = mask((j > -kRoundMagic) & (j < kRoundMagic));  // &: no branch
    *r = select(in_range, ((x - j * kPio2A) - j * kPio2B) - j * kPio2C, x - x);
    *q = int32_t(select(in_range, j, 0.0f));
}
inline float sin_poly(float r, float z) {
    return r + r * z * ((-1.9515295891e-4f * z + 8.3321608736e-3f) * z - 1.6666654611e-1f);
}
inline float cos_poly(float z) {
    return 1.0f - 0.5f * z +
           z * z * ((2.443315711809948e-5f * z - 1.388731625493765e-3f) * z + 4.166664568298827e-2f);
}
// x with its sign bit xor-ed with bit 31 of `sign` (no branch: the loops below vectorise).
inline float flip_sign(float x, uint32_t sign) {
    uint32_t bits;
    std::memcpy(&bits, &x, 4);
    bits ^= sign;
    std::memcpy(&x, &bits, 4);
    return x;
}
// sin(r + q pi/2): q odd takes the cosine polynomial, q & 2 negates. cos(x) = sin(x + pi/2),
// i.e. the same with q + 1.
inline float quadrant_sin(uint32_t q, float ps, float pc) {
    return flip_sign(select(mask((q & 1u) != 0), pc, ps), (q & 2u) << 30);
}
}  // namespace sine_detail

// s[i] = sin(x[i]), c[i] = cos(x[i]) for i < n.
inline void sincos_reduced(const float* x, float* s, float* c, size_t n) {
    using namespace sine_detail;
    for (size_t i = 0; i < n; ++i) {
        float r;
        int32_t q;
        reduce(x[i], &r, &q);
        const float z = r * r, ps = sin_poly(r, z), pc = cos_poly(z);
        s[i] = quadrant_sin(uint32_t(q), ps, pc);
        c[i] = quadrant_sin(uint32_t(q) + 1u, ps, pc);
    }
}

// s[i] = sin(x[i]) for i < n; equal to sincos_reduced's s, bit for bit.
inline void sin_reduced(const float* x, float* s, size_t n) {
    using namespace sine_detail;
    for (size_t i = 0; i < n; ++i) {
        float r;
        int32_t q;
        reduce(x[i], &r, &q);
        const float z = r * r;
        s[i] = quadrant_sin(uint32_t(q), sin_poly(r, z), cos_poly(z));
    }
}

}  // namespace nfd
