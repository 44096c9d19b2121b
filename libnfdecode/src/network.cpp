// CPU reference evaluator (FORMAT.md "Evaluation"): positional encoding, sine layers, linear
// output, all in f32. Points are processed in blocks with activations stored feature-major
// (h[feature][point]), so the inner loop of every layer runs over points and vectorises; sin and
// cos are the C library's, accurate on the whole f32 range (no range-reduction shortcut).
#include <algorithm>
#include <cmath>
#include <vector>

#include "network.h"
#include "parallel.h"

namespace nfd {
namespace {

constexpr size_t kBlock = 64;  // points per block: acc[] stays in registers/L1

struct Scratch {
    std::vector<float> a, b;  // ping-pong activations, max_width x kBlock
};

float activate_output(OutputActivation activation, float y) {
    switch (activation) {
        case OutputActivation::Abs: return std::fabs(y);
        case OutputActivation::Sigmoid: return 1.0f / (1.0f + std::exp(-y));
        case OutputActivation::Identity: break;
    }
    return y;
}

void evaluate_block(const Network& net, const float* xyz, size_t count, float* out, Scratch& s) {
    float* h = s.a.data();
    // Encoding: [u0, u1, u2, then per frequency sin(f u0..2), cos(f u0..2)].
    for (size_t p = 0; p < count; ++p)
        for (size_t j = 0; j < 3; ++j) h[j * kBlock + p] = xyz[3 * p + j];
    for (size_t k = 0; k < net.frequencies.size(); ++k) {
        const float f = net.frequencies[k];
        for (size_t j = 0; j < 3; ++j) {
            float* sin_row = h + (3 + 6 * k + j) * kBlock;
            float* cos_row = sin_row + 3 * kBlock;
            for (size_t p = 0; p < count; ++p) {
                const float arg = f * xyz[3 * p + j];  // the f32 product FORMAT.md specifies
                sin_row[p] = std::sin(arg);
                cos_row[p] = std::cos(arg);
            }
        }
    }

    float* next = s.b.data();
    for (size_t l = 0; l < net.layers.size(); ++l) {
        const Layer& layer = net.layers[l];
        const bool hidden = l + 1 < net.layers.size();
        for (uint32_t o = 0; o < layer.out; ++o) {
            float acc[kBlock] = {};
            const float* w = layer.weights.data() + size_t(o) * layer.in;
            for (uint32_t i = 0; i < layer.in; ++i) {
                const float wi = w[i];
                const float* hi = h + size_t(i) * kBlock;
                for (size_t p = 0; p < count; ++p) acc[p] += wi * hi[p];
            }
            float* row = next + size_t(o) * kBlock;
            for (size_t p = 0; p < count; ++p) {
                const float z = acc[p] + layer.bias[o];
                row[p] = hidden ? std::sin(net.omega0 * z) : z;
            }
        }
        std::swap(h, next);
    }
    for (size_t p = 0; p < count; ++p) out[p] = activate_output(net.output, h[p]);
}

}  // namespace

void evaluate_cpu(const Network& network, const float* unit_xyz, size_t n, float* out,
                  unsigned threads) {
    size_t width = network.input_width();
    for (const Layer& layer : network.layers) width = std::max<size_t>(width, layer.out);
    // Below ~4k points a thread costs more than it saves.
    parallel_for(n, 4096, threads, [&](size_t begin, size_t end) {
        Scratch s{std::vector<float>(width * kBlock), std::vector<float>(width * kBlock)};
        for (size_t p = begin; p < end; p += kBlock) {
            const size_t count = std::min(kBlock, end - p);
            evaluate_block(network, unit_xyz + 3 * p, count, out + p, s);
        }
    });
}

}  // namespace nfd
