// CPU reference evaluator (FORMAT.md "Evaluation"): positional encoding, sine layers, linear
// output, all in f32, optionally with the gradient (reverse mode). Points are processed in blocks
// with activations stored feature-major (h[feature][point]), so the inner loop of every layer runs
// over points and vectorises; sin and cos are sine.h's (the shaders' reduction and polynomials,
// ~1 ulp), evaluated over whole rows.
#include <algorithm>
#include <atomic>
#include <cmath>
#include <iterator>
#include <type_traits>
#include <vector>

#include "network.h"
#include "parallel.h"
#include "sine.h"

namespace nfd {
namespace {

constexpr size_t kBlock = 64;  // points per block: acc[] stays in registers/L1

// Rows are stored feature-major: feature i of point p is h[i * kBlock + p], so that every row
// runs over points and vectorises.
struct Scratch {
    nfd::vector<float> a, b;  // ping-pong rows, widest() x kBlock
    // The gradient path: the encoded input's rows, and each hidden layer's slopes
    // omega0 cos(omega0 z), its rows after the previous layer's.
    nfd::vector<float> encoding, slopes;
};

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

// Rows of a layer computed together (outputs in layer_rows, inputs in back_rows): each row loaded
// feeds this many accumulators (the loads, not the multiply-adds, bound a one-row loop).
constexpr uint32_t kOutputBlock = 4;

// fn(block, first) over [0, n): blocks of kOutputBlock rows, then single rows; `block` is a
// std::integral_constant, so that the row kernels are instantiated for both sizes.
template <class Fn>
void in_blocks(uint32_t n, Fn&& fn) {
    uint32_t first = 0;
    for (; first + kOutputBlock <= n; first += kOutputBlock)
        fn(std::integral_constant<uint32_t, kOutputBlock>(), first);
    for (; first < n; ++first) fn(std::integral_constant<uint32_t, 1>(), first);
}

// N points of one row as one vector register of the instruction set a build is for (16 on
// AVX-512, 8 on AVX2, 4 otherwise: kBuilds below), written as GCC's (and Clang's) generic
// vectors; RowLanes reads and writes them inside rows of floats (any alignment, aliasing them).
// A vector wider than the instruction set's registers is not split well (16 lanes ran 6x slower
// in the AVX2 build than 8), hence one width per build.
template <size_t N>
struct LaneTypes {
    typedef float Lanes __attribute__((vector_size(N * sizeof(float))));
    typedef float RowLanes __attribute__((vector_size(N * sizeof(float)), aligned(4), may_alias));
};
constexpr size_t kLaneGroups = 2;  // vectors per accumulator row: 2 x B registers in flight

// acc[b][p] = sum_k coefficient(b, k) * rows[k * kBlock + p] for b < B and the points p < count,
// the terms added in k order. The points go N * kLaneGroups at a time with their B sums in
// registers, so that each loaded row feeds B accumulators and nothing else touches memory until
// the sums are done (accumulators in memory made the loads and stores, not the arithmetic, the
// bound: this is 1.2-1.5x faster). The last group may run past `count` up to kBlock: those
// points' rows hold earlier blocks' (or zero-initialised) values, and their sums are never read.
template <size_t N, uint32_t B, class Coefficient>
void sum_rows(uint32_t terms, Coefficient&& coefficient, const float* rows, size_t count,
              float (&acc)[kOutputBlock][kBlock]) {
    using Lanes = typename LaneTypes<N>::Lanes;
    using RowLanes = typename LaneTypes<N>::RowLanes;
    static_assert(kBlock % (N * kLaneGroups) == 0, "a block is whole groups of lanes");
    for (size_t p0 = 0; p0 < count; p0 += N * kLaneGroups) {
        Lanes sum[B][kLaneGroups] = {};
        for (uint32_t k = 0; k < terms; ++k) {
            const RowLanes* x = reinterpret_cast<const RowLanes*>(rows + size_t(k) * kBlock + p0);
            for (uint32_t b = 0; b < B; ++b) {
                const float c = coefficient(b, k);
                for (size_t g = 0; g < kLaneGroups; ++g) sum[b][g] += c * x[g];
            }
        }
        for (uint32_t b = 0; b < B; ++b)
            for (size_t g = 0; g < kLaneGroups; ++g)
                reinterpret_cast<RowLanes*>(acc[b] + p0)[g] = sum[b][g];
    }
}

// Rows o .. o + B - 1 of a layer over `count` points: acc[b][p] = sum_i w[o + b][i] x[i][p], in
// input order. The gradient path's forward pass is this one (value_layer), so its values are the
// value path's bit for bit; network.cpp is compiled without floating-point contraction, so no
// instruction-set build fuses the multiply-adds differently.
template <size_t N, uint32_t B>
void layer_rows(const Layer& layer, uint32_t o, const float* h, size_t count,
                float (&acc)[kOutputBlock][kBlock]) {
    const float* w = layer.weights.data() + size_t(o) * layer.in;
    const uint32_t in = layer.in;
    sum_rows<N, B>(
        in, [w, in](uint32_t b, uint32_t i) { return w[size_t(b) * in + i]; }, h, count, acc);
}

// One layer: outputs kOutputBlock at a time, then the activation of each output row as one array
// of arguments; with `slopes` (the gradient path's forward pass, hidden layers) also each
// output's omega0 cos(omega0 z), from the same sincos (whose sine is sin_reduced's, bit for bit).
template <size_t N>
void value_layer(const Network& net, const Layer& layer, bool hidden, const float* h, size_t count,
                 float* next, float* slopes = nullptr) {
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
        if (!slopes) return sin_reduced(args, value, count);
        float* slope = slopes + size_t(o) * kBlock;
        sincos_reduced(args, value, slope, count);
        for (size_t p = 0; p < count; ++p) slope[p] *= net.omega0;
    };
    in_blocks(layer.out, [&](auto block, uint32_t o) {
        layer_rows<N, block>(layer, o, h, count, acc);
        for (uint32_t b = 0; b < block; ++b) finish(o + b, acc[b]);
    });
}

// The encoded input into rows (FORMAT.md order): u0, u1, u2, then per frequency sin(f u0..2),
// cos(f u0..2).
void encode_block(const Network& net, const float* xyz, size_t count, float* h) {
    for (size_t j = 0; j < 3; ++j)
        for (size_t p = 0; p < count; ++p) h[j * kBlock + p] = xyz[3 * p + j];
    float args[kBlock];
    for (size_t k = 0; k < net.frequencies.size(); ++k) {
        const float f = net.frequencies[k];
        for (size_t j = 0; j < 3; ++j) {
            const size_t sin_feature = 3 + 6 * k + j, cos_feature = sin_feature + 3;
            for (size_t p = 0; p < count; ++p) args[p] = f * xyz[3 * p + j];  // FORMAT.md's f32 product
            sincos_reduced(args, h + sin_feature * kBlock, h + cos_feature * kBlock, count);
        }
    }
}

// Values of every output of each point, point-major (a colour network's RGB).
template <size_t N>
void value_block(const Network& net, const float* xyz, size_t count, float* out, Scratch& s) {
    float *h = s.a.data(), *next = s.b.data();
    encode_block(net, xyz, count, h);
    for (size_t l = 0; l < net.layers.size(); ++l) {
        value_layer<N>(net, net.layers[l], l + 1 < net.layers.size(), h, count, next);
        std::swap(h, next);
    }
    const uint32_t outputs = net.output_width();
    for (uint32_t o = 0; o < outputs; ++o)
        for (size_t p = 0; p < count; ++p)
            out[p * outputs + o] = activate_output(net.output, h[o * kBlock + p]);
}

// The derivative of the output with respect to inputs i .. i + B - 1 of `layer`, given it with
// respect to the layer's outputs (rows `delta`): acc[b][p] = sum_o w[o][i + b] delta[o][p], in
// output order; each row loaded feeds B accumulators, as in layer_rows.
template <size_t N, uint32_t B>
void back_rows(const Layer& layer, uint32_t i, const float* delta, size_t count,
               float (&acc)[kOutputBlock][kBlock]) {
    const float* w = layer.weights.data() + i;
    const uint32_t in = layer.in;
    sum_rows<N, B>(
        layer.out, [w, in](uint32_t b, uint32_t o) { return w[size_t(o) * in + b]; }, delta, count,
        acc);
}

// fn(i, row) for every input i of `layer` with row the derivative of the output with respect to
// it (back_rows, four inputs at a time).
template <size_t N, class Fn>
void back_layer(const Layer& layer, const float* delta, size_t count, Fn&& fn) {
    float acc[kOutputBlock][kBlock];
    in_blocks(layer.in, [&](auto block, uint32_t i) {
        back_rows<N, block>(layer, i, delta, count, acc);
        for (uint32_t b = 0; b < block; ++b) fn(i + b, acc[b]);
    });
}

// Values and gradients of a network with one output, in reverse mode (as field_eval.comp's
// WITH_GRADIENT): the forward pass is the value path's (the same rows, so the same value bit for
// bit) and keeps each hidden unit's slope; the output's derivative then goes back through the
// transposed weights, times the slopes, and at layer 0 through the encoding: sin(f u_a) has
// derivative f cos(f u_a) along axis a, cos(f u_a) has -f sin(f u_a). About two value passes'
// work, where forward mode (a value and three derivative rows through every layer) took three to
// four (bench/RESULTS.md "0.13.2").
template <size_t N>
void gradient_block(const Network& net, const float* xyz, size_t count, float* out,
                    float* out_gradients, Scratch& s) {
    const float* encoding = s.encoding.data();
    encode_block(net, xyz, count, s.encoding.data());
    float* rows[2] = {s.a.data(), s.b.data()};
    const size_t layers = net.layers.size();
    for (size_t l = 0, slope = 0; l < layers; ++l) {
        const bool hidden = l + 1 < layers;
        value_layer<N>(net, net.layers[l], hidden, l == 0 ? encoding : rows[(l - 1) & 1], count,
                    rows[l & 1], hidden ? s.slopes.data() + slope : nullptr);
        if (hidden) slope += size_t(net.layers[l].out) * kBlock;
    }
    // The output, and its derivative with respect to the last layer's one output.
    const float* y = rows[(layers - 1) & 1];
    float* delta = rows[layers & 1];
    for (size_t p = 0; p < count; ++p) {
        out[p] = activate_output(net.output, y[p]);
        delta[p] = output_slope(net.output, y[p]);
    }
    // Back through the layers above layer 0: each input of layer l is an output of hidden layer
    // l - 1, whose slope row multiplies it.
    size_t slope = 0;
    for (size_t l = 0; l + 2 < layers; ++l) slope += size_t(net.layers[l].out) * kBlock;
    for (size_t l = layers - 1; l > 0; --l) {
        float* below = delta == rows[0] ? rows[1] : rows[0];
        const float* slopes = s.slopes.data() + slope;
        back_layer<N>(net.layers[l], delta, count, [&](uint32_t i, const float* d) {
            for (size_t p = 0; p < count; ++p)
                below[i * kBlock + p] = d[p] * slopes[i * kBlock + p];
        });
        delta = below;
        if (l > 1) slope -= size_t(net.layers[l - 2].out) * kBlock;
    }
    // Layer 0 and the encoding, into one row per axis.
    float gradient[3][kBlock] = {};
    back_layer<N>(net.layers[0], delta, count, [&](uint32_t i, const float* d) {
        if (i < 3) {
            for (size_t p = 0; p < count; ++p) gradient[i][p] += d[p];
            return;
        }
        const uint32_t k = (i - 3) / 6, j = (i - 3) % 6;
        const float f = net.frequencies[k];
        if (j < 3) {  // sin(f u_j): f cos(f u_j), the cos row 3 features on
            const float* c = encoding + size_t(i + 3) * kBlock;
            for (size_t p = 0; p < count; ++p) gradient[j][p] += d[p] * (f * c[p]);
        } else {  // cos(f u_j): -f sin(f u_j)
            const float* sn = encoding + size_t(i - 3) * kBlock;
            for (size_t p = 0; p < count; ++p) gradient[j - 3][p] += d[p] * (-f * sn[p]);
        }
    });
    for (size_t p = 0; p < count; ++p)
        for (size_t a = 0; a < 3; ++a) out_gradients[3 * p + a] = gradient[a][p];
}

size_t widest(const Network& net) {
    size_t width = net.input_width();
    for (const Layer& layer : net.layers) width = std::max<size_t>(width, layer.out);
    return width;
}

// The blocks of [begin, end), with rows of N lanes.
template <size_t N>
void value_range(const Network& net, const float* unit_xyz, size_t begin, size_t end, float* out,
                 Scratch& s) {
    for (size_t p = begin; p < end; p += kBlock)
        value_block<N>(net, unit_xyz + 3 * p, std::min(kBlock, end - p),
                       out + p * net.output_width(), s);
}

template <size_t N>
void gradient_range(const Network& net, const float* unit_xyz, size_t begin, size_t end,
                    float* out, float* out_gradients, Scratch& s) {
    for (size_t p = begin; p < end; p += kBlock)
        gradient_block<N>(net, unit_xyz + 3 * p, std::min(kBlock, end - p), out + p,
                          out_gradients + 3 * p, s);
}

// Both paths built for each instruction set, with everything they call inlined (`flatten`), so
// that the row loops and the vectors of sum_rows are the set's own: 16 lanes on AVX-512, 8 on
// AVX2, 4 on the x86-64 baseline; the widest the CPU has is picked at first use. Without
// contraction every build computes the same bits. GCC on x86-64 Linux builds all three; other
// compilers and targets (Clang's builds serve the fuzzers) and ThreadSanitizer builds, which test
// the threads rather than the instruction sets, build the baseline only (4 lanes: SSE, NEON).
struct RangeFunctions {
    void (*values)(const Network&, const float*, size_t, size_t, float*, Scratch&);
    void (*gradients)(const Network&, const float*, size_t, size_t, float*, float*, Scratch&);
};
#define NFD_RANGE_FUNCTIONS(NAME, ATTRIBUTES, LANES)                                              \
    ATTRIBUTES void NAME##_values(const Network& net, const float* xyz, size_t begin, size_t end, \
                                  float* out, Scratch& s) {                                       \
        value_range<LANES>(net, xyz, begin, end, out, s);                                         \
    }                                                                                             \
    ATTRIBUTES void NAME##_gradients(const Network& net, const float* xyz, size_t begin,         \
                                     size_t end, float* out, float* gradients, Scratch& s) {      \
        gradient_range<LANES>(net, xyz, begin, end, out, gradients, s);                           \
    }

struct Build {
    unsigned lanes;
    RangeFunctions functions;
    bool (*supported)();  // null: every CPU
};
#if defined(__x86_64__) && defined(__linux__) && defined(__GNUC__) && !defined(__clang__) && \
    !defined(__SANITIZE_THREAD__)
NFD_RANGE_FUNCTIONS(avx512, __attribute__((target("avx512f"), flatten)), 16)
NFD_RANGE_FUNCTIONS(avx2, __attribute__((target("avx2"), flatten)), 8)
NFD_RANGE_FUNCTIONS(baseline, __attribute__((flatten)), 4)
bool has_avx512() { return __builtin_cpu_init(), __builtin_cpu_supports("avx512f"); }
bool has_avx2() { return __builtin_cpu_init(), __builtin_cpu_supports("avx2"); }
constexpr Build kBuilds[] = {{16, {avx512_values, avx512_gradients}, has_avx512},
                             {8, {avx2_values, avx2_gradients}, has_avx2},
                             {4, {baseline_values, baseline_gradients}, nullptr}};
#else
NFD_RANGE_FUNCTIONS(baseline, , 4)
constexpr Build kBuilds[] = {{4, {baseline_values, baseline_gradients}, nullptr}};
#endif
#undef NFD_RANGE_FUNCTIONS

// The widest build this CPU runs with at most `max_lanes` lanes (0: any), else the baseline.
const Build* widest_build(unsigned max_lanes) {
    for (const Build& b : kBuilds)
        if ((!max_lanes || b.lanes <= max_lanes) && (!b.supported || b.supported())) return &b;
    return &kBuilds[std::size(kBuilds) - 1];
}
std::atomic<const Build*> g_build{nullptr};
const RangeFunctions& ranges() {
    const Build* b = g_build.load(std::memory_order_acquire);
    if (!b) {  // first use; a cap set meanwhile (set_cpu_evaluator_lanes) stays
        const Build* widest = widest_build(0);
        b = g_build.compare_exchange_strong(b, widest, std::memory_order_acq_rel) ? widest : b;
    }
    return b->functions;
}

// The rows of every hidden layer's outputs: the gradient path's slopes.
size_t hidden_rows(const Network& net) {
    size_t rows = 0;
    for (size_t l = 0; l + 1 < net.layers.size(); ++l) rows += net.layers[l].out;
    return rows;
}

// Floats of a thread's Scratch: two rows of the widest layer; with gradients also the encoded
// input's and the slopes' rows.
size_t scratch_floats(const Network& net, bool gradients) {
    return (2 * widest(net) + (gradients ? net.input_width() + hidden_rows(net) : 0)) * kBlock;
}

void evaluate_blocks(const Network& net, const float* unit_xyz, size_t n, float* out,
                     float* out_gradients, unsigned threads) {
    const bool gradients = out_gradients != nullptr;
    const size_t width = widest(net) * kBlock;
    const size_t encoding = gradients ? net.input_width() * kBlock : 0;
    const size_t slopes = gradients ? hidden_rows(net) * kBlock : 0;
    // Below ~4k points a thread costs more than it saves.
    parallel_for(n, 4096, threads, [&](size_t begin, size_t end) {
        Scratch s{nfd::vector<float>(width), nfd::vector<float>(width),
                  nfd::vector<float>(encoding), nfd::vector<float>(slopes)};
        if (gradients)
            ranges().gradients(net, unit_xyz, begin, end, out, out_gradients, s);
        else
            ranges().values(net, unit_xyz, begin, end, out, s);
    });
}

}  // namespace

unsigned set_cpu_evaluator_lanes(unsigned max_lanes) {
    const Build* b = widest_build(max_lanes);
    g_build.store(b, std::memory_order_release);
    return b->lanes;
}

ShapeBall ShapeBall::of_truncation(float truncation) {
    const float radius = 1.0f + 2.0f * truncation;
    return {radius * radius, truncation};
}

void ShapeBall::bound(const float* unit_xyz, size_t n, float* values, size_t stride) const {
    for (size_t i = 0; i < n; ++i, unit_xyz += 3) {
        const float x = unit_xyz[0], y = unit_xyz[1], z = unit_xyz[2];
        float& value = values[i * stride];
        // Not std::max: a NaN stays NaN, as the meshers expect it.
        if (x * x + y * y + z * z > radius_sq && value < floor) value = floor;
    }
}

size_t evaluate_scratch_bytes(const Network& network, bool gradients, unsigned threads) {
    // Per thread its Scratch, its std::thread state and exception slot (1 KB covers).
    const size_t per_thread = scratch_floats(network, gradients) * sizeof(float);
    return resolve_thread_count(threads) * (per_thread + 1024);
}

void evaluate_cpu(const Network& network, const float* unit_xyz, size_t n, float* out,
                  unsigned threads) {
    evaluate_blocks(network, unit_xyz, n, out, nullptr, threads);
}

void evaluate_gradient_cpu(const Network& network, const float* unit_xyz, size_t n,
                           float* out_values, float* out_gradients, unsigned threads) {
    evaluate_blocks(network, unit_xyz, n, out_values, out_gradients, threads);
}

}  // namespace nfd
