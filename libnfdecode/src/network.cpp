// CPU reference evaluator (FORMAT.md "Evaluation"): positional encoding, sine layers, linear
// output, all in f32, optionally with the forward-mode gradient. Points are processed in blocks
// with activations stored feature-major (h[feature][point]), so the inner loop of every layer runs
// over points and vectorises; sin and cos are sine.h's (the shaders' reduction and polynomials,
// ~1 ulp), evaluated over whole rows.
#include <algorithm>
#include <cmath>
#include <vector>

#include "network.h"
#include "parallel.h"
#include "sine.h"

namespace nfd {
namespace {

constexpr size_t kBlock = 64;  // points per block: acc[] stays in registers/L1

// Activations are stored feature-major with C components per feature: the value (component 0)
// and, for the gradient path (C = 4), its derivatives along x, y, z. Component c of feature i for
// point p is h[(i * C + c) * kBlock + p]: every component row runs over points and vectorises.
struct Scratch {
    nfd::vector<float> a, b;  // ping-pong activations, max_width x C x kBlock
};

// The axis whose coordinate encoded input i depends on (FORMAT.md order: u, then per frequency
// sin xyz, cos xyz): its derivative along the two other axes is zero.
uint32_t encoded_axis(uint32_t i) { return i < 3 ? i : (i - 3) % 3; }

float activate_output(OutputActivation activation, float y) {
    switch (activation) {
        case OutputActivation::Abs: return std::fabs(y);
        case OutputActivation::Sigmoid: return 1.0f / (1.0f + std::exp(-y));
        case OutputActivation::Identity: break;
    }
    return y;
}

// d activate_output / dy at y (abs: sign(y) with sign(0) = +1).
float output_slope(OutputActivation activation, float y) {
    switch (activation) {
        case OutputActivation::Abs: return y >= 0.0f ? 1.0f : -1.0f;
        case OutputActivation::Sigmoid: {
            const float s = 1.0f / (1.0f + std::exp(-y));
            return s * (1.0f - s);
        }
        case OutputActivation::Identity: break;
    }
    return 1.0f;
}

// Outputs of a layer computed together in the value path: each input row loaded feeds this many
// accumulators (the loads, not the multiply-adds, bound a one-output loop).
constexpr uint32_t kOutputBlock = 4;

// Rows o .. o + B - 1 of a layer over `count` points: acc[b][p] = sum_i w[o + b][i] x[i][p].
// acc += w * x is the one multiply-add of every layer, in input order, for values and derivatives
// alike (gradient_rows), so that the value of the gradient path is the value path's, bit for bit;
// network.cpp is compiled without floating-point contraction, so no path fuses it differently.
template <uint32_t B>
void layer_rows(const Layer& layer, uint32_t o, const float* h, size_t count,
                float (&acc)[kOutputBlock][kBlock]) {
    for (uint32_t b = 0; b < B; ++b) std::fill_n(acc[b], count, 0.0f);
    const float* w = layer.weights.data() + size_t(o) * layer.in;
    for (uint32_t i = 0; i < layer.in; ++i) {
        const float* x = h + size_t(i) * kBlock;
        float wi[B];
        for (uint32_t b = 0; b < B; ++b) wi[b] = w[size_t(b) * layer.in + i];
        for (size_t p = 0; p < count; ++p)
            for (uint32_t b = 0; b < B; ++b) acc[b][p] += wi[b] * x[p];
    }
}

// The value path (C = 1) of one layer: outputs kOutputBlock at a time, then the activation of
// each output row as one array of arguments.
void value_layer(const Network& net, const Layer& layer, bool hidden, const float* h, size_t count,
                 float* next) {
    float acc[kOutputBlock][kBlock];
    float args[kBlock];
    auto finish = [&](uint32_t o, const float* sum) {
        float* value = next + size_t(o) * kBlock;
        const float bias = layer.bias[o];
        if (!hidden) {
            for (size_t p = 0; p < count; ++p) value[p] = sum[p] + bias;
            return;
        }
        for (size_t p = 0; p < count; ++p) args[p] = net.omega0 * (sum[p] + bias);
        sin_reduced(args, value, count);
    };
    uint32_t o = 0;
    for (; o + kOutputBlock <= layer.out; o += kOutputBlock) {
        layer_rows<kOutputBlock>(layer, o, h, count, acc);
        for (uint32_t b = 0; b < kOutputBlock; ++b) finish(o + b, acc[b]);
    }
    for (; o < layer.out; ++o) {
        layer_rows<1>(layer, o, h, count, acc);
        finish(o, acc[0]);
    }
}

// Rows o .. o + B - 1 of a layer in the gradient path (C = 4): every derivative row goes through
// the same weights as its value, each accumulator summed in input order as in layer_rows.
// Layer 0's encoded inputs depend on one coordinate each: only that
// derivative row is read (the others are zero). Blocked as layer_rows: each row loaded feeds B
// accumulators.
constexpr size_t kGradientComponents = 4;
template <uint32_t B>
void gradient_rows(const Layer& layer, uint32_t o, bool first, const float* h, size_t count,
                   float (&acc)[kOutputBlock][kGradientComponents][kBlock]) {
    constexpr size_t C = kGradientComponents;
    for (uint32_t b = 0; b < B; ++b)
        for (size_t c = 0; c < C; ++c) std::fill_n(acc[b][c], count, 0.0f);
    const float* w = layer.weights.data() + size_t(o) * layer.in;
    for (uint32_t i = 0; i < layer.in; ++i) {
        float wi[B];
        for (uint32_t b = 0; b < B; ++b) wi[b] = w[size_t(b) * layer.in + i];
        const float* x = h + size_t(i) * C * kBlock;
        for (size_t c = 0; c < C; ++c) {
            if (first && c > 0 && c != 1 + encoded_axis(i)) continue;
            const float* xc = x + c * kBlock;
            for (size_t p = 0; p < count; ++p)
                for (uint32_t b = 0; b < B; ++b) acc[b][c][p] += wi[b] * xc[p];
        }
    }
}

// The gradient path (C = 4) of one layer: outputs kOutputBlock at a time (gradient_rows), then
// the chain rule of the activation.
void gradient_layer(const Network& net, const Layer& layer, bool first, bool hidden,
                    const float* h, size_t count, float* next) {
    constexpr size_t C = kGradientComponents;
    float acc[kOutputBlock][C][kBlock];
    float args[kBlock], sines[kBlock], cosines[kBlock];
    auto finish = [&](uint32_t o, float (&sum)[C][kBlock]) {
        float* value = next + (size_t(o) * C) * kBlock;
        if (!hidden) {  // the output layer is linear
            for (size_t p = 0; p < count; ++p) value[p] = sum[0][p] + layer.bias[o];
            for (size_t c = 1; c < C; ++c) std::copy_n(sum[c], count, value + c * kBlock);
            return;
        }
        // d sin(omega0 z) = omega0 cos(omega0 z) dz.
        for (size_t p = 0; p < count; ++p) args[p] = net.omega0 * (sum[0][p] + layer.bias[o]);
        sincos_reduced(args, sines, cosines, count);
        std::copy_n(sines, count, value);
        for (size_t c = 1; c < C; ++c)
            for (size_t p = 0; p < count; ++p)
                value[c * kBlock + p] = net.omega0 * cosines[p] * sum[c][p];
    };
    uint32_t o = 0;
    for (; o + kOutputBlock <= layer.out; o += kOutputBlock) {
        gradient_rows<kOutputBlock>(layer, o, first, h, count, acc);
        for (uint32_t b = 0; b < kOutputBlock; ++b) finish(o + b, acc[b]);
    }
    for (; o < layer.out; ++o) {
        gradient_rows<1>(layer, o, first, h, count, acc);
        finish(o, acc[0]);
    }
}

// C = 1: values; C = 4: values and gradients (forward mode).
template <size_t C>
void evaluate_block(const Network& net, const float* xyz, size_t count, float* out,
                    float* out_gradients, Scratch& s) {
    float* h = s.a.data();
    auto row = [](float* base, size_t feature, size_t c) {
        return base + (feature * C + c) * kBlock;
    };
    // Encoding: [u0, u1, u2, then per frequency sin(f u0..2), cos(f u0..2)]. Derivative rows are
    // written only along the input's own axis (the others are zero and layer 0 skips them).
    for (size_t j = 0; j < 3; ++j) {
        for (size_t p = 0; p < count; ++p) row(h, j, 0)[p] = xyz[3 * p + j];
        if (C > 1) std::fill_n(row(h, j, 1 + j), count, 1.0f);
    }
    float args[kBlock];
    for (size_t k = 0; k < net.frequencies.size(); ++k) {
        const float f = net.frequencies[k];
        for (size_t j = 0; j < 3; ++j) {
            const size_t sin_feature = 3 + 6 * k + j, cos_feature = sin_feature + 3;
            float* sin_row = row(h, sin_feature, 0);
            float* cos_row = row(h, cos_feature, 0);
            for (size_t p = 0; p < count; ++p) args[p] = f * xyz[3 * p + j];  // FORMAT.md's f32 product
            sincos_reduced(args, sin_row, cos_row, count);
            if (C > 1) {
                float* dsin = row(h, sin_feature, 1 + j);
                float* dcos = row(h, cos_feature, 1 + j);
                for (size_t p = 0; p < count; ++p) {
                    dsin[p] = f * cos_row[p];
                    dcos[p] = -f * sin_row[p];
                }
            }
        }
    }

    float* next = s.b.data();
    for (size_t l = 0; l < net.layers.size(); ++l) {
        const bool hidden = l + 1 < net.layers.size();
        if (C == 1)
            value_layer(net, net.layers[l], hidden, h, count, next);
        else
            gradient_layer(net, net.layers[l], l == 0, hidden, h, count, next);
        std::swap(h, next);
    }
    // Values: every output of the point, point-major (a colour network's RGB). Gradients: the
    // geometry's one output.
    const uint32_t outputs = net.output_width();
    for (uint32_t o = 0; o < outputs; ++o) {
        const float* y = row(h, o, 0);
        for (size_t p = 0; p < count; ++p) out[p * outputs + o] = activate_output(net.output, y[p]);
    }
    if (C == 1) return;
    for (size_t p = 0; p < count; ++p) {
        const float slope = output_slope(net.output, h[p]);
        for (size_t c = 1; c < C; ++c) out_gradients[3 * p + c - 1] = slope * row(h, 0, c)[p];
    }
}

size_t widest(const Network& net) {
    size_t width = net.input_width();
    for (const Layer& layer : net.layers) width = std::max<size_t>(width, layer.out);
    return width;
}

// The blocks of [begin, end): one function per path, compiled once for each instruction set
// below (GCC's function multiversioning: the loader picks the widest the CPU has) with everything
// it calls inlined, so that the row loops vectorise 16 wide on AVX-512, 8 on AVX2, 4 on the
// x86-64 baseline. Without contraction every clone computes the same bits. Clang 14 refuses
// `flatten` on clones, and without it the callees would stay baseline: other compilers build
// the baseline only. ThreadSanitizer builds too: the clones' resolver runs while the dynamic
// loader relocates, before TSan's runtime is up, and the instrumented resolver crashed there.
#if defined(__x86_64__) && defined(__linux__) && defined(__GNUC__) && !defined(__clang__) && \
    !defined(__SANITIZE_THREAD__)
#define NFD_VECTOR_CLONES __attribute__((target_clones("avx512f", "avx2", "default"), flatten))
#else
#define NFD_VECTOR_CLONES
#endif

NFD_VECTOR_CLONES void value_range(const Network& net, const float* unit_xyz, size_t begin,
                                   size_t end, float* out, Scratch& s) {
    for (size_t p = begin; p < end; p += kBlock)
        evaluate_block<1>(net, unit_xyz + 3 * p, std::min(kBlock, end - p),
                          out + p * net.output_width(), nullptr, s);
}

NFD_VECTOR_CLONES void gradient_range(const Network& net, const float* unit_xyz, size_t begin,
                                      size_t end, float* out, float* out_gradients, Scratch& s) {
    for (size_t p = begin; p < end; p += kBlock)
        evaluate_block<4>(net, unit_xyz + 3 * p, std::min(kBlock, end - p), out + p,
                          out_gradients + 3 * p, s);
}

template <size_t C>
void evaluate_blocks(const Network& net, const float* unit_xyz, size_t n, float* out,
                     float* out_gradients, unsigned threads) {
    const size_t width = widest(net);
    // Below ~4k points a thread costs more than it saves.
    parallel_for(n, 4096, threads, [&](size_t begin, size_t end) {
        Scratch s{nfd::vector<float>(width * C * kBlock), nfd::vector<float>(width * C * kBlock)};
        if (C == 1)
            value_range(net, unit_xyz, begin, end, out, s);
        else
            gradient_range(net, unit_xyz, begin, end, out, out_gradients, s);
    });
}

}  // namespace

size_t evaluate_scratch_bytes(const Network& network, bool gradients, unsigned threads) {
    // Per thread two activation buffers, its std::thread state and exception slot (1 KB covers).
    const size_t per_thread = 2 * widest(network) * (gradients ? 4 : 1) * kBlock * sizeof(float);
    return resolve_thread_count(threads) * (per_thread + 1024);
}

void evaluate_cpu(const Network& network, const float* unit_xyz, size_t n, float* out,
                  unsigned threads) {
    evaluate_blocks<1>(network, unit_xyz, n, out, nullptr, threads);
}

void evaluate_gradient_cpu(const Network& network, const float* unit_xyz, size_t n,
                           float* out_values, float* out_gradients, unsigned threads) {
    evaluate_blocks<4>(network, unit_xyz, n, out_values, out_gradients, threads);
}

}  // namespace nfd
