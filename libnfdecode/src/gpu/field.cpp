// The field stage: the network uploaded for field_eval.comp, its evaluation (values, or values
// and gradients) recorded into a batch, and the plain evaluate calls of gpu_decode.h. The CPU
// twin is network.cpp.
#include <algorithm>
#include <cstring>
#include <iterator>
#include <new>
#include <system_error>
#include <thread>

#include "../parallel.h"
#include "device.h"
#include "gpu_decode.h"

namespace nfd::gpu {
namespace {

constexpr uint32_t kPointsPerInvocation = 8;          // field_eval.comp's POINTS (rows: below)
// field_eval_lanes.comp: a workgroup of NFD_FIELD_LANES invocations evaluates NFD_FIELD_LANES x 32
// points per load of its weights; for networks whose layers are at most 12 vec4s (48 units) wide.
constexpr uint32_t kLanePointsPerInvocation = 32;
constexpr uint32_t kLaneKernelWidest4 = 12;
constexpr uint32_t kMaxVec4PerLayer = NFD_GPU_MAX_WIDTH / 4;
constexpr VkDeviceSize kUniformBlockBytes = NFD_GPU_UNIFORM_VEC4S * 16;
constexpr VkDeviceSize kFrequencyBytes = NFD_GPU_MAX_FREQUENCIES * 4;
constexpr size_t kEvaluateChunk = size_t(1) << 22;    // points per dispatch in evaluate()
// Networks kept on a device: a few hundred KB of weights each at most (width 96: 80 KB).
constexpr size_t kCachedNetworks = 8;
// Field pipelines compiled on the device's own threads at once (compile_in_background): two
// per network shape, for four shapes.
constexpr size_t kMaxWarmers = 8;

bool same_network(const Network& a, const Network& b) {
    if (a.frequencies != b.frequencies || a.omega0 != b.omega0 || a.output != b.output ||
        a.ball.radius_sq != b.ball.radius_sq || a.ball.floor != b.ball.floor ||
        a.layers.size() != b.layers.size())
        return false;
    for (size_t l = 0; l < a.layers.size(); ++l) {
        const Layer &x = a.layers[l], &y = b.layers[l];
        if (x.in != y.in || x.out != y.out || x.weights != y.weights || x.bias != y.bias)
            return false;
    }
    return true;
}

// Column of layer 0's input element e (FORMAT.md order: u, then per frequency sin xyz, cos xyz)
// in field_eval.comp's order: vec4 0 = (u, 0), then per block of 4 frequencies the vec4s
// sin(f u_x), sin(f u_y), sin(f u_z), cos(f u_x), cos(f u_y), cos(f u_z), one frequency per lane.
uint32_t encoded_column(uint32_t e) {
    if (e < 3) return e;
    const uint32_t k = (e - 3) / 6, j = (e - 3) % 6;
    return 4 * (1 + 6 * (k / 4) + j) + k % 4;
}

// The device's entry for `kernel` at `specialization` (built or being built), or the list's end.
// Called with d.mutex held.
std::list<Device::FieldPipeline>::iterator find_field_pipeline(
    Device& d, Kernel kernel, const std::vector<uint32_t>& specialization) {
    return std::find_if(d.field_pipelines.begin(), d.field_pipelines.end(),
                        [&](const Device::FieldPipeline& f) {
                            return f.kernel == kernel && f.specialization == specialization;
                        });
}

// The pipeline of `kernel` for a network shape, created on first use and kept by the device.
// Called with d.mutex held by `lock`, which is released while compiling: another thread that
// needs the same pipeline meanwhile waits for this compile rather than starting its own.
nfd_result field_pipeline(Device& d, std::unique_lock<std::mutex>& lock, Kernel kernel,
                          const std::vector<uint32_t>& specialization, const Pipeline** out) {
    for (auto it = find_field_pipeline(d, kernel, specialization); it != d.field_pipelines.end();
         it = find_field_pipeline(d, kernel, specialization)) {
        if (it->ready) {
            *out = &it->pipeline;
            return NFD_SUCCESS;
        }
        d.field_pipeline_ready.wait(lock);  // then look again: that compile may have failed
    }
    d.field_pipelines.push_back({kernel, specialization, {}, false});
    const auto entry = std::prev(d.field_pipelines.end());
    Pipeline built;
    lock.unlock();
    nfd_result r;
    try {
        r = d.vk->create_pipeline(kernel_pipeline(kernel, specialization), &built);
    } catch (const std::bad_alloc&) {
        r = NFD_ERROR_OUT_OF_MEMORY;
    }
    lock.lock();
    if (r == NFD_SUCCESS) {
        entry->pipeline = std::move(built);
        entry->ready = true;
        *out = &entry->pipeline;
    } else {
        d.field_pipelines.erase(entry);
    }
    d.field_pipeline_ready.notify_all();
    return r;
}

// Evaluates n points kEvaluateChunk at a time, handing each chunk's results (output_width()
// floats per point, or a vec4 with `gradient`) to take(first point, count, results).
template <class Take>
nfd_result evaluate_in_chunks(Device& device, const Network& network, const float* unit_xyz,
                              size_t n, bool gradient, Take&& take) {
    if (n == 0) return NFD_SUCCESS;
    if (gradient && network.output_width() != 1) return NFD_ERROR_INTERNAL;  // no such caller
    std::shared_ptr<DeviceNetwork> uploaded;
    NFD_TRY(device_network(device, network, &uploaded));
    DeviceNetwork& net = *uploaded;
    Job job(device, true);
    NFD_TRY(job.init());
    Buffers buffers(*device.vk);
    const size_t chunk = std::min(n, kEvaluateChunk);
    Buffer *points, *results;
    NFD_TRY(buffers.make(chunk * 12, &points, Memory::Host));
    NFD_TRY(buffers.make(chunk * (gradient ? 16 : 4 * network.output_width()), &results,
                         Memory::Host));
    for (size_t begin = 0; begin < n; begin += chunk) {
        const uint32_t count = uint32_t(std::min(chunk, n - begin));
        std::memcpy(points->data, unit_xyz + 3 * begin, size_t(count) * 12);
        NFD_TRY(job.begin());
        NFD_TRY(record_field(job, net, *points, *results, Count{count}, gradient, ShapeBall{}));
        NFD_TRY(job.submit());
        take(begin, count, results->as<float>());
    }
    return NFD_SUCCESS;
}

// Vec4 rows per layer: in4 inputs (layer 0: the encoding's blocks), out4 outputs; with
// transposed blocks (field_eval_lanes.comp's gradient), the columns each holds.
struct LayerVec4s {
    uint32_t freq4 = 0;  // the encoding's frequency blocks of 4
    uint32_t in4[NFD_GPU_MAX_LAYERS] = {};
    uint32_t out4[NFD_GPU_MAX_LAYERS] = {};
    uint32_t transposed_columns[NFD_GPU_MAX_LAYERS] = {};
};

// field_eval_lanes.comp's gradient reads layer l's weights by columns: lane `lane`'s column slot
// s is transposed row s * NFD_FIELD_LANES + lane. For a hidden layer that is input column s *
// LANES + lane (zero past the inputs); for layer 0 the shader's pairs: slot s of 2 * pair_slots
// + 1 is the sine (s even) or cosine (s odd) column of (frequency k, axis a) pair q = (s / 2) *
// LANES + lane, q = 3k + a, and the last slot the coordinate u_lane on lanes 0-2. The column
// in the block's row layout, or UINT32_MAX for a zero row.
uint32_t transposed_source_column(uint32_t layer, uint32_t row, uint32_t in4, uint32_t freq4) {
    if (layer > 0) return row < 4 * in4 ? row : UINT32_MAX;
    const uint32_t pairs = 12 * freq4, pair_slots = div_up(pairs, NFD_FIELD_LANES);
    const uint32_t slot = row / NFD_FIELD_LANES, lane = row % NFD_FIELD_LANES;
    if (slot == 2 * pair_slots) return lane < 3 ? lane : UINT32_MAX;
    const uint32_t q = (slot / 2) * NFD_FIELD_LANES + lane, k = q / 3, axis = q % 3;
    if (q >= pairs) return UINT32_MAX;
    return 4 + 24 * (k / 4) + 4 * (axis + 3 * (slot % 2)) + k % 4;
}

// Where field_eval.comp finds each layer (device.h, DeviceNetwork: ranges, offsets, storage or
// uniform) and the kernel's specialization: from the network's shape alone, so that a shape read
// ahead of its weights (warm_field_pipelines) gives the very pipelines of the whole network.
nfd_result network_layout(const Device& d, const Network& net, DeviceNetwork* out,
                          LayerVec4s* v) {
    const VkPhysicalDeviceLimits& limits = d.vk->limits();
    const uint32_t layers = uint32_t(net.layers.size());
    if (layers < 1 || layers > NFD_GPU_MAX_LAYERS ||
        net.frequencies.size() > NFD_GPU_MAX_FREQUENCIES || net.output_width() < 1 ||
        net.output_width() > 4)
        return NFD_ERROR_UNSUPPORTED_FEATURE;
    const uint32_t freq4 = v->freq4 = div_up(net.frequencies.size(), 4);
    std::fill(std::begin(v->out4), std::end(v->out4), 1u);
    uint32_t in = net.input_width();
    for (uint32_t l = 0; l < layers; ++l) {
        const Layer& layer = net.layers[l];
        if (layer.in != in || layer.out == 0) return NFD_ERROR_UNSUPPORTED_FEATURE;
        v->in4[l] = l == 0 ? 1 + 6 * freq4 : v->out4[l - 1];
        v->out4[l] = div_up(layer.out, 4);
        if (v->out4[l] > kMaxVec4PerLayer) return NFD_ERROR_UNSUPPORTED_FEATURE;
        in = layer.out;
    }
    out->max4 = v->in4[0];
    for (uint32_t l = 0; l < layers; ++l) {
        out->max4 = std::max(out->max4, v->out4[l]);
        out->widest4 = std::max(out->widest4, v->out4[l]);
    }

    // Uniform blocks are what makes field_eval.comp fast on CPU implementations; a layer too
    // large for one (64 KiB: 128 rows of 99 inputs) takes the storage-buffer variant, slower
    // there but exact.
    const VkDeviceSize block =
        std::min<VkDeviceSize>(kUniformBlockBytes, limits.maxUniformBufferRange);
    for (uint32_t l = 0; l < layers; ++l) {
        out->range[l] = VkDeviceSize(v->out4[l]) * (4 * v->in4[l] + 1) * 16;
        out->storage |= out->range[l] > block;
        out->weight_vec4s += uint32_t(out->range[l] / 16);
    }
    // The lanes kernel's transposed blocks after each layer's, for networks with a gradient (one
    // output) where every enlarged block still fits a uniform block (else their gradients stay
    // with field_eval.comp).
    out->transposed = d.lane_kernels && !out->storage && out->widest4 <= kLaneKernelWidest4 &&
                      net.output_width() == 1;
    for (uint32_t l = 0; l < layers; ++l) {
        const uint32_t slots = l == 0 ? 2 * div_up(12 * freq4, NFD_FIELD_LANES) + 1
                                      : div_up(4 * v->in4[l], NFD_FIELD_LANES);
        v->transposed_columns[l] = slots * NFD_FIELD_LANES;
        out->transposed &=
            out->range[l] + VkDeviceSize(v->transposed_columns[l]) * v->out4[l] * 16 <= block;
    }
    for (uint32_t l = 0; l < layers; ++l) {
        if (!out->transposed) v->transposed_columns[l] = 0;
        out->range[l] += VkDeviceSize(v->transposed_columns[l]) * v->out4[l] * 16;
    }
    const VkDeviceSize align = std::max<VkDeviceSize>(
        256, out->storage ? limits.minStorageBufferOffsetAlignment
                          : limits.minUniformBufferOffsetAlignment);
    VkDeviceSize total = 0;
    for (uint32_t l = 0; l < layers; ++l) {
        out->offset[l] = total;
        total += (out->range[l] + align - 1) / align * align;
    }
    out->bytes = total;
    for (uint32_t l = layers; l < NFD_GPU_MAX_LAYERS; ++l) out->range[l] = out->range[0];  // unused

    float omega0 = net.omega0;
    uint32_t omega0_bits;
    std::memcpy(&omega0_bits, &omega0, 4);
    std::vector<uint32_t>& spec = out->specialization;
    spec = {freq4, layers};
    spec.insert(spec.end(), std::begin(v->out4), std::end(v->out4));
    spec.insert(spec.end(), {omega0_bits, uint32_t(net.output), out->max4, net.output_width()});
    return NFD_SUCCESS;
}

// Per layer, rows of in4 vec4s at aligned offsets (device.h, DeviceNetwork).
nfd_result upload_network(Device& d, const Network& net, DeviceNetwork* out) {
    LayerVec4s v;
    NFD_TRY(network_layout(d, net, out, &v));
    out->ball = net.ball;
    const uint32_t layers = uint32_t(net.layers.size());
    for (const Layer& layer : net.layers)
        if (layer.weights.size() != size_t(layer.in) * layer.out || layer.bias.size() != layer.out)
            return NFD_ERROR_UNSUPPORTED_FEATURE;  // not a network the parser produces
    const VkDeviceSize total = out->bytes;
    out->device = &d;
    NFD_TRY(d.vk->create_buffer(total, &out->weights));
    NFD_TRY(d.vk->create_buffer(kFrequencyBytes, &out->frequencies));
    std::vector<float> weights(total / 4, 0.0f), frequencies(kFrequencyBytes / 4, 0.0f);
    std::copy(net.frequencies.begin(), net.frequencies.end(), frequencies.begin());
    for (uint32_t l = 0; l < layers; ++l) {
        const Layer& layer = net.layers[l];
        float* w = weights.data() + out->offset[l] / 4;
        for (uint32_t o = 0; o < layer.out; ++o) {
            float* row = w + size_t(o) * 4 * v.in4[l];
            for (uint32_t i = 0; i < layer.in; ++i)
                row[l == 0 ? encoded_column(i) : i] = layer.weights[size_t(o) * layer.in + i];
        }
        float* bias = w + size_t(v.out4[l]) * 4 * 4 * v.in4[l];
        for (uint32_t o = 0; o < layer.out; ++o) bias[o] = layer.bias[o];
        float* transposed = bias + 4 * v.out4[l];
        for (uint32_t r = 0; r < v.transposed_columns[l]; ++r) {
            const uint32_t c = transposed_source_column(l, r, v.in4[l], v.freq4);
            if (c == UINT32_MAX) continue;
            for (uint32_t o = 0; o < layer.out; ++o)
                transposed[size_t(r) * 4 * v.out4[l] + o] = w[size_t(o) * 4 * v.in4[l] + c];
        }
    }
    NFD_TRY(d.vk->upload(out->weights, 0, weights.data(), total));
    NFD_TRY(d.vk->upload(out->frequencies, 0, frequencies.data(), kFrequencyBytes));
    return NFD_SUCCESS;
}

// The pipeline prepare_field uses for a network's value or gradient kernel: its kernel, its
// specialization and the points each invocation evaluates.
struct FieldKernel {
    Kernel kernel;
    std::vector<uint32_t> specialization;
    uint32_t points;
};

FieldKernel field_kernel(const Device& d, const DeviceNetwork& net, bool gradient) {
    // Fewer points per invocation for wide networks bounds the per-invocation activations. The
    // gradient variant runs as many as the value variant: with half as many, its per-point time
    // on 2-core llvmpipe (bunny UDF, width 32) was 5% worse; with a quarter, 30% worse.
    // On a GPU, the shared-memory shape wherever every layer's block fits the workgroup's memory.
    const bool shared = d.shared_weight_kernels && !net.storage &&
                        VkDeviceSize(net.weight_vec4s) * 16 <= d.vk->limits().maxComputeSharedMemorySize;
    // On CPU implementations the values of networks up to 48 wide take the lanes kernel (the
    // same bits), and their gradients its gradient variant where the network's blocks carry the
    // transposes it reads (the same values; gradients within rounding). Wider ones keep
    // field_eval.comp: the lanes kernel's unrolled rows cost more to create with its width, even
    // from Mesa's shader cache (2-core lavapipe, in every process: 45-75 ms at widths 16-32,
    // 130-200 at 48, 250-350 at 64 against field_eval.comp's 35, and 2.7 s more than
    // field_eval.comp for a machine's first compile at 64), which at 64 about equals what a
    // decode at 256 gains (bench/RESULTS.md, "0.13.14"); the gradient variant costs about three
    // times the value kernel's ("0.13.16").
    const bool lanes = d.lane_kernels && !shared && !net.storage &&
                       net.widest4 <= kLaneKernelWidest4 && (!gradient || net.transposed);
    FieldKernel f;
    f.points = lanes ? kLanePointsPerInvocation : shared ? 1 : net.max4 <= 32 ? kPointsPerInvocation : 2;
    f.specialization = net.specialization;
    f.specialization.push_back(f.points);
    if (shared)
        f.specialization.insert(f.specialization.end(),
                                {0u /* local size: set by the pipeline */, net.weight_vec4s});
    f.kernel = lanes    ? (gradient ? Kernel::FieldGradientLanes : Kernel::FieldEvalLanes)
               : shared ? (gradient ? Kernel::FieldGradientShared : Kernel::FieldEvalShared)
               : gradient ? (net.storage ? Kernel::FieldGradientStorage : Kernel::FieldGradient)
                          : (net.storage ? Kernel::FieldEvalStorage : Kernel::FieldEval);
    return f;
}

}  // namespace

DeviceNetwork::~DeviceNetwork() {
    if (!device) return;
    device->vk->destroy(weights);
    device->vk->destroy(frequencies);
}

nfd_result device_network(Device& d, const Network& net, std::shared_ptr<DeviceNetwork>* out) {
    std::lock_guard<std::mutex> lock(d.mutex);
    for (auto it = d.networks.begin(); it != d.networks.end(); ++it) {
        if (same_network(it->network, net)) {
            d.networks.splice(d.networks.begin(), d.networks, it);  // most recently used
            *out = it->uploaded;
            return NFD_SUCCESS;
        }
    }
    try {
        auto uploaded = std::make_shared<DeviceNetwork>();
        NFD_TRY(upload_network(d, net, uploaded.get()));
        d.networks.push_front({net, uploaded});
        if (d.networks.size() > kCachedNetworks) d.networks.pop_back();  // users keep theirs alive
        ++d.networks_uploaded;
        *out = std::move(uploaded);
    } catch (const std::bad_alloc&) {
        return NFD_ERROR_OUT_OF_MEMORY;
    }
    return NFD_SUCCESS;
}

nfd_result prepare_field(Device& d, DeviceNetwork& net, bool gradient) {
    std::unique_lock<std::mutex> lock(d.mutex);
    DeviceNetwork::Variant& variant = gradient ? net.gradients : net.values;
    if (variant.pipeline) return NFD_SUCCESS;
    const FieldKernel f = field_kernel(d, net, gradient);
    const Pipeline* pipeline = nullptr;
    NFD_TRY(field_pipeline(d, lock, f.kernel, f.specialization, &pipeline));
    variant.points_per_invocation = f.points;
    variant.pipeline = pipeline;
    return NFD_SUCCESS;
}

bool field_ready(Device& d, const DeviceNetwork& net, bool gradient) {
    std::lock_guard<std::mutex> lock(d.mutex);
    if ((gradient ? net.gradients : net.values).pipeline) return true;
    const FieldKernel f = field_kernel(d, net, gradient);
    const auto it = find_field_pipeline(d, f.kernel, f.specialization);
    return it != d.field_pipelines.end() && it->ready;
}

namespace {

// A network's layout without its buffers (the destructor then frees nothing): what a pipeline
// compiled on another thread needs, whose lifetime the network's owner does not control.
std::shared_ptr<DeviceNetwork> layout_copy(const DeviceNetwork& net) {
    auto layout = std::make_shared<DeviceNetwork>();
    std::copy(std::begin(net.offset), std::end(net.offset), std::begin(layout->offset));
    std::copy(std::begin(net.range), std::end(net.range), std::begin(layout->range));
    layout->storage = net.storage;
    layout->max4 = net.max4;
    layout->widest4 = net.widest4;
    layout->weight_vec4s = net.weight_vec4s;
    layout->transposed = net.transposed;
    layout->bytes = net.bytes;
    layout->specialization = net.specialization;
    return layout;
}

// Compiles the value or gradient pipeline of `layout` on a thread of the device
// (Device::warmers), into the device's list, where prepare_field finds it or waits for it. A
// UDF's two run on two threads: its first levels wait for the values' pipeline, its meshed levels
// for the gradients'. On a CPU implementation the gradients' runs at the lowest priority: it
// takes about three times as long to create there, and at normal priority it took the core of the
// first level's host evaluation (bench/RESULTS.md, "0.13.16"); the decode's own device work is
// CPU work there, so the compile yields to it and runs while the decode waits for it. (Not on a
// GPU, whose compiles are short, where a lowest-priority thread on a busy host could starve.)
// False when no thread could start, or kMaxWarmers are running: the pipeline is then compiled
// where it is first needed.
bool compile_in_background(Device& d, std::shared_ptr<DeviceNetwork> layout, bool gradient) {
    std::lock_guard<std::mutex> lock(d.mutex);
    d.join_warmers(true);
    if (d.warmers.size() >= kMaxWarmers) return false;
    Device::Warmer& w = d.warmers.emplace_back();
    try {
        w.thread = std::thread([&d, &w, layout, gradient] {
            if (gradient && d.vk->cpu_implementation()) run_as_lowest_priority_thread();
            else run_as_background_thread();
            try {  // a failure is the decode's to report
                prepare_field(d, *layout, gradient);
            } catch (const std::bad_alloc&) {
            }
            w.done = true;
        });
    } catch (const std::system_error&) {
        d.warmers.pop_back();
        return false;
    }
    return true;
}

}  // namespace

nfd_result prepare_fields(Device& d, DeviceNetwork& net, FieldType field) {
    bool value_missing, gradient_missing;
    {
        std::lock_guard<std::mutex> lock(d.mutex);  // else every later decode started threads
        value_missing = !net.values.pipeline;
        gradient_missing = field == FieldType::Udf && !net.gradients.pipeline;
    }
    if (!value_missing && !gradient_missing) return NFD_SUCCESS;
    try {
        if (value_missing) compile_in_background(d, layout_copy(net), false);
        if (gradient_missing) compile_in_background(d, layout_copy(net), true);
    } catch (const std::bad_alloc&) {
        return NFD_ERROR_OUT_OF_MEMORY;
    }
    return NFD_SUCCESS;
}

void warm_field_pipelines(Device& d, const Network& shape, FieldType field) {
    try {
        auto layout = std::make_shared<DeviceNetwork>();
        LayerVec4s v;
        if (network_layout(d, shape, layout.get(), &v) != NFD_SUCCESS) return;
        compile_in_background(d, layout, false);
        if (field == FieldType::Udf) compile_in_background(d, layout, true);
    } catch (const std::bad_alloc&) {
    }
}

nfd_result record_field(Job& job, DeviceNetwork& net, const Buffer& points, const Buffer& results,
                        Count count, bool gradient, const ShapeBall& ball) {
    NFD_TRY(prepare_field(job.device, net, gradient));
    const DeviceNetwork::Variant& variant = gradient ? net.gradients : net.values;
    const Buffer& w = net.weights;
    auto layer = [&](uint32_t l) -> Bind {
        return {NFD_B_FIELD_LAYER0 + l, BufferRange(w, net.offset[l], net.range[l])};
    };
    const struct {
        uint32_t capacity, first, slot;
        float ball_radius_sq, ball_floor;
    } push = {count.capacity, count.first, count.slot, ball.radius_sq, ball.floor};
    static_assert(sizeof(push) == NFD_FIELD_PUSH_BYTES, "field_eval.comp's Push");
    return job.dispatch(*variant.pipeline,
                        {{NFD_B_FIELD_POINTS, points}, {NFD_B_FIELD_VALUES, results},
                         {NFD_B_FIELD_FREQUENCIES, net.frequencies}, layer(0), layer(1), layer(2),
                         layer(3), layer(4), layer(5), layer(6), layer(7)},
                        &push, count, variant.points_per_invocation);
}

nfd_result evaluate(Device& device, const Network& network, const float* unit_xyz, size_t n,
                    float* out) {
    const size_t outputs = network.output_width();
    return evaluate_in_chunks(device, network, unit_xyz, n, false,
                              [&](size_t begin, uint32_t count, const float* r) {
                                  std::memcpy(out + begin * outputs, r, count * outputs * 4);
                              });
}

nfd_result evaluate_gradient(Device& device, const Network& network, const float* unit_xyz,
                             size_t n, float* values, float* gradients) {
    return evaluate_in_chunks(device, network, unit_xyz, n, true,
                              [&](size_t begin, uint32_t count, const float* r) {
                                  for (size_t i = 0; i < count; ++i, r += 4) {
                                      values[begin + i] = r[0];
                                      std::copy(r + 1, r + 4, gradients + 3 * (begin + i));
                                  }
                              });
}

}  // namespace nfd::gpu
