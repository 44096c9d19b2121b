// Dequantized neural field and its CPU reference evaluator (FORMAT.md, "Evaluation").
#pragma once
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <vector>

#include "host_memory.h"

namespace nfd {

enum class FieldType : uint8_t { Sdf = 0, Udf = 1 };
enum class OutputActivation : uint8_t { Identity = 0, Abs = 1, Sigmoid = 2 };

struct Layer {
    uint32_t in = 0, out = 0;
    nfd::vector<float> weights;  // out x in, row-major: weights[o * in + i]
    nfd::vector<float> bias;     // out
};

// The shape's ball (FORMAT.md, "The shape's ball"): an encoder puts the shape inside the unit ball
// of its frame, so a surface that a geometry field shows farther than 2 d* outside that ball is
// the fit's error (a loosely held corner of [-1, 1]^3), not the shape. Wherever a decoder grids the
// field (the grid's values, which the schedule, the meshers and the VDB output read) it reads
// max(f, d*) at the points with x*x + y*y + z*z > (1 + 2 d*)^2 (f32, in that order, no fused
// multiply-add), so no surface is extracted there. The field itself (nfd_asset_evaluate) is not
// bounded.
struct ShapeBall {
    float radius_sq = INFINITY;  // (1 + 2 d*)^2; infinity: unbounded (colour networks)
    float floor = 0.0f;          // d*
    static ShapeBall of_truncation(float truncation);
    // Raises values[i * stride] to the floor at the points beyond the ball.
    void bound(const float* unit_xyz, size_t n, float* values, size_t stride = 1) const;
};

struct Network {
    nfd::vector<float> frequencies;  // f[k] of FORMAT.md, already rounded to f32
    float omega0 = 30.0f;
    OutputActivation output = OutputActivation::Identity;
    uint32_t bits = 8;
    nfd::vector<Layer> layers;       // hidden sine layers then one linear output layer
    ShapeBall ball;                  // where a geometry field is gridded; unbounded otherwise

    uint32_t input_width() const { return 3u + 6u * uint32_t(frequencies.size()); }
    uint32_t output_width() const { return layers.empty() ? 0u : layers.back().out; }
};

// The frame in f64 (FORMAT.md `fram`, 1.2): original = unit * scale + center, exactly.
struct Frame64 {
    double center[3] = {0, 0, 0};
    double scale = 1.0;
};

// Geometry chunk after parsing and dequantization. Positions in the original frame are
// u * scale + center for u in the unit frame [-1, 1]^3.
struct Geometry {
    FieldType field = FieldType::Sdf;
    float truncation = 0.1f;
    float center[3] = {0, 0, 0};  // GEOM's f32 frame (nfd_asset_info)
    float scale = 1.0f;
    std::optional<Frame64> frame64;
    Network network;

    // Where outputs are placed (FORMAT.md "Output positions"): positions are emitted in f32 as
    // u * scale + emit_center(), relative to offset(). Without a 64-bit frame that is GEOM's f32
    // center and a zero offset, as in 1.0; with one, zero and the exact center, so that positions
    // stay small and exact while the offset carries the far translation in f64.
    float emit_center(int axis) const { return frame64 ? 0.0f : center[axis]; }
    double offset(int axis) const { return frame64 ? frame64->center[axis] : 0.0; }
};

// Evaluates the field at n points given in the unit frame (xyz interleaved), writing
// output_width() values per point, point-major: n distances for a geometry, n RGB triples for a
// colour network. Plain C++17, f32 accumulation; the oracle for the GPU path and the fallback
// without a device. Multithreaded over points: `threads` workers at most, 0 = hardware
// concurrency.
void evaluate_cpu(const Network& network, const float* unit_xyz, size_t n, float* out,
                  unsigned threads = 0);

// Values and analytic gradients (d value / d unit-frame coordinate, 3 floats per point) by
// reverse-mode differentiation through the output activation (abs: sign(y) with sign(0) = +1;
// sigmoid: s (1 - s)), the sine layers and the encoding, of a network with one output: the
// shaders' order (field_eval.comp's WITH_GRADIENT), not their bits. out_values are
// bit-identical to evaluate_cpu's; `threads` as there.
void evaluate_gradient_cpu(const Network& network, const float* unit_xyz, size_t n,
                           float* out_values, float* out_gradients, unsigned threads = 0);

// The CPU evaluator is built for several vector widths, the widest the machine has chosen at
// first use: 16 lanes (AVX-512), 8 (AVX2), 4 (the baseline; other compilers and CPUs build only
// it). All compute the same bits. This caps the width for the evaluations that start after it
// (0: no cap) and returns the width they use: tests compare the builds with it.
unsigned set_cpu_evaluator_lanes(unsigned max_lanes);

// An upper bound of the bytes one evaluate_cpu (or, with `gradients`, evaluate_gradient_cpu) call
// allocates: its threads' activation scratch and their bookkeeping.
size_t evaluate_scratch_bytes(const Network& network, bool gradients, unsigned threads);

}  // namespace nfd
