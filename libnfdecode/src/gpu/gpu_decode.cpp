// The Vulkan compute path (gpu_decode.h): uploads a network, evaluates points, and runs the sparse
// coarse-to-fine extraction and marching cubes of extract_cpu.cpp as compute kernels (shaders/).
// The host only sizes buffers between kernels from counts it reads back; every per-cell and
// per-point loop runs on the device.
#include "gpu_decode.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstring>
#include <list>
#include <new>

#include "../mc_tables.h"
#include "vk_context.h"

namespace nfd::gpu {
namespace {

constexpr uint32_t kMaxNetworkLayers = 8;   // field_eval.comp binds one block per layer
constexpr uint32_t kMaxFrequencies = 24;    // its Frequencies block holds 6 vec4s
constexpr uint32_t kUniformBlockBytes = 65536;  // its uniform blocks declare 4096 vec4s
constexpr uint32_t kFieldLocalSize = 32;
constexpr uint32_t kMaxVec4PerLayer = 128;  // MAX_WIDTH / 4
constexpr uint32_t kPointsPerInvocation = 8;
constexpr size_t kEvaluateChunk = size_t(1) << 22;  // points per dispatch in evaluate()

using Clock = std::chrono::steady_clock;
double seconds_since(Clock::time_point t0) {
    return std::chrono::duration<double>(Clock::now() - t0).count();
}

uint32_t div_up(uint64_t a, uint64_t b) { return uint32_t((a + b - 1) / b); }

#define NFD_TRY(expr)                             \
    do {                                          \
        nfd_result nfd_try_ = (expr);             \
        if (nfd_try_ != NFD_SUCCESS) return nfd_try_; \
    } while (0)

// Buffers that live as long as this object (one refinement level, one batch of work).
class Buffers {
public:
    explicit Buffers(Context& vk) : vk_(&vk) {}
    ~Buffers() { release(); }
    Buffers(Buffers&& other) noexcept : vk_(other.vk_), list_(std::move(other.list_)) {}
    Buffers& operator=(Buffers&& other) noexcept {
        release();
        vk_ = other.vk_;
        list_ = std::move(other.list_);
        return *this;
    }
    nfd_result make(VkDeviceSize bytes, Buffer** out) {
        std::unique_ptr<Buffer> b(new (std::nothrow) Buffer());
        if (!b) return NFD_ERROR_OUT_OF_MEMORY;
        NFD_TRY(vk_->create_buffer(bytes, b.get()));
        list_.push_back(std::move(b));
        *out = list_.back().get();
        return NFD_SUCCESS;
    }
    void release() {
        for (auto& b : list_) vk_->destroy(*b);
        list_.clear();
    }

private:
    Context* vk_;
    std::vector<std::unique_ptr<Buffer>> list_;
};

// Push constants of the level kernels (extract.glsl, LevelPush).
struct LevelPush {
    float center[4] = {0, 0, 0, 0};
    uint32_t parent_cells = 0, child_cells = 0, count = 0, child_level = 0;
    float step = 0, threshold = 0, scale = 1;
};

}  // namespace

class Device {
public:
    std::unique_ptr<Context> vk;

    // field_eval variants, one per network shape (its sizes are specialization constants).
    struct FieldKernel {
        std::vector<uint32_t> specialization;
        bool storage = false, gradient = false;
        Pipeline pipeline;
    };
    std::list<FieldKernel> field_kernels;  // a list: DeviceNetwork keeps pointers into it

    Pipeline refine_count, refine_points, refine_cells, gather_corners, bitmap_compact;
    Pipeline scan, scan_popcount, scan_add, mc_classify, mc_emit, mc_vertices;
    Buffer mc_tables;

    ~Device() {
        if (!vk) return;
        for (FieldKernel& k : field_kernels) vk->destroy(k.pipeline);
        for (Pipeline* p : {&refine_count, &refine_points, &refine_cells, &gather_corners,
                            &bitmap_compact, &scan, &scan_popcount, &scan_add, &mc_classify,
                            &mc_emit, &mc_vertices})
            vk->destroy(*p);
        vk->destroy(mc_tables);
    }
};

namespace {

nfd_result create_kernels(Device& d) {
    const VkDescriptorType S = VK_DESCRIPTOR_TYPE_STORAGE_BUFFER;
    auto make = [&](const shaders::Spirv& spirv, uint32_t bindings, uint32_t push_bytes,
                    uint32_t local_size, std::vector<uint32_t> specialization, Pipeline* out) {
        PipelineDesc desc;
        desc.spirv = &spirv;
        desc.bindings.assign(bindings, S);
        desc.push_constant_bytes = push_bytes;
        desc.local_size = local_size;
        desc.specialization = std::move(specialization);
        return d.vk->create_pipeline(desc, out);
    };
    const uint32_t level = sizeof(LevelPush);
    NFD_TRY(make(shaders::refine_count, 8, level, 64, {}, &d.refine_count));
    NFD_TRY(make(shaders::refine_points, 8, level, 64, {}, &d.refine_points));
    NFD_TRY(make(shaders::refine_cells, 8, level, 64, {}, &d.refine_cells));
    NFD_TRY(make(shaders::gather_corners, 9, level, 64, {}, &d.gather_corners));
    NFD_TRY(make(shaders::mc_classify, 13, level, 64, {}, &d.mc_classify));
    NFD_TRY(make(shaders::mc_emit, 14, level, 64, {}, &d.mc_emit));
    NFD_TRY(make(shaders::mc_vertices, 13, level, 64, {}, &d.mc_vertices));
    NFD_TRY(make(shaders::bitmap_compact, 3, 4, 64, {}, &d.bitmap_compact));
    NFD_TRY(make(shaders::scan, 3, 4, 256, {0}, &d.scan));
    NFD_TRY(make(shaders::scan, 3, 4, 256, {1}, &d.scan_popcount));
    NFD_TRY(make(shaders::scan_add, 3, 4, 256, {}, &d.scan_add));

    // The marching-cubes tables, exactly as the CPU reference uses them (mc.glsl's layout).
    const mc::Tables& t = mc::tables();
    std::vector<int32_t> table(256 * 16 + 256 + 24);
    for (int c = 0; c < 256; ++c) {
        for (int i = 0; i < 16; ++i) table[16 * c + i] = t.triangles[c][i];
        table[4096 + c] = t.triangle_count[c];
    }
    for (int e = 0; e < 12; ++e)
        for (int j = 0; j < 2; ++j) table[4096 + 256 + 2 * e + j] = mc::kEdgeCorners[e][j];
    NFD_TRY(d.vk->create_buffer(table.size() * 4, &d.mc_tables));
    std::memcpy(d.mc_tables.data, table.data(), table.size() * 4);
    return NFD_SUCCESS;
}

// A network uploaded for field_eval.comp: per layer, rows of in4 vec4s (the output padded to a
// multiple of 4 with zero rows, layer 0's columns permuted to the shader's encoding order), then
// the bias, at offsets aligned for uniform binding.
struct DeviceNetwork {
    Device* device = nullptr;
    Buffer weights, frequencies;
    VkDeviceSize offset[kMaxNetworkLayers] = {}, range[kMaxNetworkLayers] = {};
    bool storage = false;
    uint32_t max4 = 0;                    // widest layer input/output, in vec4s
    std::vector<uint32_t> specialization;  // field_eval.comp's constants 0-12
    struct Kernel {
        const Pipeline* pipeline = nullptr;  // created on first use
        uint32_t points_per_invocation = 1;
    } values, gradients;
    DeviceNetwork() = default;
    DeviceNetwork(const DeviceNetwork&) = delete;
    ~DeviceNetwork() {
        if (!device) return;
        device->vk->destroy(weights);
        device->vk->destroy(frequencies);
    }
};

// Column of layer 0's input element e (FORMAT.md order: u, then per frequency sin xyz, cos xyz)
// in field_eval.comp's order: vec4 0 = (u, 0), then per block of 4 frequencies the vec4s
// sin(f u_x), sin(f u_y), sin(f u_z), cos(f u_x), cos(f u_y), cos(f u_z), one frequency per lane.
uint32_t encoded_column(uint32_t e) {
    if (e < 3) return e;
    const uint32_t k = (e - 3) / 6, j = (e - 3) % 6;
    return 4 * (1 + 6 * (k / 4) + j) + k % 4;
}

nfd_result get_field_kernel(Device& d, const std::vector<uint32_t>& specialization, bool storage,
                            bool gradient, const Pipeline** out) {
    for (const Device::FieldKernel& k : d.field_kernels) {
        if (k.storage == storage && k.gradient == gradient && k.specialization == specialization) {
            *out = &k.pipeline;
            return NFD_SUCCESS;
        }
    }
    PipelineDesc desc;
    desc.spirv = gradient ? (storage ? &shaders::field_gradient_storage : &shaders::field_gradient)
                          : (storage ? &shaders::field_eval_storage : &shaders::field_eval);
    desc.bindings = {VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER,
                     VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER};
    desc.bindings.resize(3 + kMaxNetworkLayers, storage ? VK_DESCRIPTOR_TYPE_STORAGE_BUFFER
                                                        : VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER);
    desc.push_constant_bytes = 4;  // the point count
    desc.local_size = kFieldLocalSize;
    desc.local_size_id = 14;
    desc.specialization = specialization;
    Device::FieldKernel kernel;
    kernel.specialization = specialization;
    kernel.storage = storage;
    kernel.gradient = gradient;
    NFD_TRY(d.vk->create_pipeline(desc, &kernel.pipeline));
    d.field_kernels.push_back(std::move(kernel));
    *out = &d.field_kernels.back().pipeline;
    return NFD_SUCCESS;
}

nfd_result upload_network(Device& d, const Network& net, DeviceNetwork* out) {
    const uint32_t layers = uint32_t(net.layers.size());
    if (layers < 1 || layers > kMaxNetworkLayers || net.frequencies.size() > kMaxFrequencies ||
        net.output_width() != 1)
        return NFD_ERROR_UNSUPPORTED_FEATURE;
    const uint32_t freq4 = div_up(net.frequencies.size(), 4);
    std::vector<uint32_t> in4(layers), out4(kMaxNetworkLayers, 1);
    uint32_t in = net.input_width();
    for (uint32_t l = 0; l < layers; ++l) {
        const Layer& layer = net.layers[l];
        if (layer.in != in || layer.out == 0 ||
            layer.weights.size() != size_t(layer.in) * layer.out || layer.bias.size() != layer.out)
            return NFD_ERROR_UNSUPPORTED_FEATURE;  // not a network the parser produces
        in4[l] = l == 0 ? 1 + 6 * freq4 : out4[l - 1];
        out4[l] = div_up(layer.out, 4);
        if (out4[l] > kMaxVec4PerLayer) return NFD_ERROR_UNSUPPORTED_FEATURE;
        in = layer.out;
    }

    // Uniform blocks are what makes field_eval.comp fast on CPU implementations; a layer too
    // large for one (64 KiB: 128 rows of 99 inputs) takes the storage-buffer variant, slower
    // there but exact.
    const VkPhysicalDeviceLimits& limits = d.vk->limits();
    const VkDeviceSize block =
        std::min<VkDeviceSize>(kUniformBlockBytes, limits.maxUniformBufferRange);
    VkDeviceSize total = 0;
    for (uint32_t l = 0; l < layers; ++l) {
        out->range[l] = VkDeviceSize(out4[l]) * (4 * in4[l] + 1) * 16;
        out->storage |= out->range[l] > block;
    }
    const VkDeviceSize align = std::max<VkDeviceSize>(
        256, out->storage ? limits.minStorageBufferOffsetAlignment
                          : limits.minUniformBufferOffsetAlignment);
    for (uint32_t l = 0; l < layers; ++l) {
        out->offset[l] = total;
        total += (out->range[l] + align - 1) / align * align;
    }
    for (uint32_t l = layers; l < kMaxNetworkLayers; ++l) out->range[l] = out->range[0];  // unused
    out->device = &d;
    NFD_TRY(d.vk->create_buffer(total, &out->weights));
    NFD_TRY(d.vk->create_buffer(6 * 16, &out->frequencies));
    std::memset(out->weights.data, 0, total);
    std::memset(out->frequencies.data, 0, 6 * 16);
    std::memcpy(out->frequencies.data, net.frequencies.data(), net.frequencies.size() * 4);
    for (uint32_t l = 0; l < layers; ++l) {
        const Layer& layer = net.layers[l];
        float* w = reinterpret_cast<float*>(static_cast<char*>(out->weights.data) + out->offset[l]);
        for (uint32_t o = 0; o < layer.out; ++o) {
            float* row = w + size_t(o) * 4 * in4[l];
            for (uint32_t i = 0; i < layer.in; ++i)
                row[l == 0 ? encoded_column(i) : i] = layer.weights[size_t(o) * layer.in + i];
        }
        float* bias = w + size_t(out4[l]) * 4 * 4 * in4[l];
        for (uint32_t o = 0; o < layer.out; ++o) bias[o] = layer.bias[o];
    }

    float omega0 = net.omega0;
    uint32_t omega0_bits;
    std::memcpy(&omega0_bits, &omega0, 4);
    out->max4 = in4[0];
    for (uint32_t l = 0; l < layers; ++l) out->max4 = std::max(out->max4, out4[l]);
    std::vector<uint32_t>& spec = out->specialization;
    spec = {freq4, layers};
    spec.insert(spec.end(), out4.begin(), out4.end());
    spec.insert(spec.end(), {omega0_bits, uint32_t(net.output), out->max4});
    return NFD_SUCCESS;
}

// Records the evaluation of `count` points into `values` (one float each), or of values and
// gradients (one vec4 each: value, d/dx, d/dy, d/dz).
nfd_result record_field(Device& d, DeviceNetwork& net, const Buffer& points, const Buffer& values,
                        uint32_t count, bool gradient = false) {
    DeviceNetwork::Kernel& kernel = gradient ? net.gradients : net.values;
    if (!kernel.pipeline) {
        // Fewer points per invocation for wide networks bounds the per-invocation activations;
        // a gradient carries four rows per point.
        const uint32_t rows = net.max4 <= 32 ? kPointsPerInvocation : 2;
        kernel.points_per_invocation = gradient ? std::max(rows / 4, 1u) : rows;
        std::vector<uint32_t> spec = net.specialization;
        spec.insert(spec.end(), {kernel.points_per_invocation, kFieldLocalSize});
        NFD_TRY(get_field_kernel(d, spec, net.storage, gradient, &kernel.pipeline));
    }
    const Buffer& w = net.weights;
    auto layer = [&](uint32_t l) { return BufferRange(w, net.offset[l], net.range[l]); };
    return d.vk->dispatch(*kernel.pipeline,
                          {points, values, net.frequencies, layer(0), layer(1), layer(2), layer(3),
                           layer(4), layer(5), layer(6), layer(7)},
                          &count, div_up(count, kernel.points_per_invocation));
}

// Records an exclusive prefix sum of `count` words of `in` (or of their popcounts) into `out`.
nfd_result record_scan(Device& d, Buffers& scratch, const Buffer& in, const Buffer& out,
                       uint32_t count, bool popcount) {
    if (count == 0) return NFD_SUCCESS;
    const uint32_t blocks = div_up(count, 1024);
    Buffer *sums, *scanned;
    NFD_TRY(scratch.make(VkDeviceSize(blocks) * 4, &sums));
    NFD_TRY(d.vk->dispatch(popcount ? d.scan_popcount : d.scan, {in, out, *sums}, &count,
                           uint64_t(blocks) * 256));
    if (blocks == 1) return NFD_SUCCESS;
    NFD_TRY(scratch.make(VkDeviceSize(blocks) * 4, &scanned));
    NFD_TRY(record_scan(d, scratch, *sums, *scanned, blocks, false));
    return d.vk->dispatch(d.scan_add, {in, out, *scanned}, &count, uint64_t(blocks) * 256);
}

uint32_t word(const Buffer& b, size_t i) { return b.as<uint32_t>()[i]; }

// The kept cells of one level, in the layout of extract.glsl.
struct Level {
    explicit Level(Context& vk) : buffers(vk) {}
    uint32_t cells = 0;  // per axis
    uint32_t kept = 0;
    Buffers buffers;
    Buffer *bits = nullptr, *prefix = nullptr, *list = nullptr, *corners = nullptr;
    uint32_t words() const { return div_up(uint64_t(cells) * cells * cells, 32); }
};

// The top level, evaluated densely; its cells are tested on the host (a few thousand), with
// extract.h's own cell_may_contain_surface. With no refinement level (resolution < 64) every
// cell of level 1 is kept, so that the finest level is visited entirely, as on the CPU.
nfd_result top_level(Device& d, DeviceNetwork& net, uint32_t resolution, uint32_t top,
                     bool test, Level* level, uint64_t* evaluated) {
    const float step = 2.0f / float(resolution);
    const uint32_t n = cells_at_level(resolution, top), side = n + 1;
    const uint32_t count = side * side * side;
    Buffers scratch(*d.vk);
    Buffer *points, *values;
    NFD_TRY(scratch.make(VkDeviceSize(count) * 12, &points));
    NFD_TRY(scratch.make(VkDeviceSize(count) * 4, &values));
    float* p = points->as<float>();
    for (uint32_t z = 0; z < side; ++z)
        for (uint32_t y = 0; y < side; ++y)
            for (uint32_t x = 0; x < side; ++x) {
                *p++ = -1.0f + float(x << top) * step;
                *p++ = -1.0f + float(y << top) * step;
                *p++ = -1.0f + float(z << top) * step;
            }
    NFD_TRY(d.vk->begin());
    NFD_TRY(record_field(d, net, *points, *values, count));
    NFD_TRY(d.vk->submit());
    *evaluated += count;

    const float h = step * float(1u << top);
    const float* f = values->as<float>();
    std::vector<uint32_t> kept;
    std::vector<float> corners;
    for (uint32_t z = 0; z < n; ++z)
        for (uint32_t y = 0; y < n; ++y)
            for (uint32_t x = 0; x < n; ++x) {
                float v[8];
                for (int c = 0; c < 8; ++c) {
                    const uint8_t* o = mc::kCornerOffset[c];
                    v[c] = f[((z + o[2]) * side + y + o[1]) * side + x + o[0]];
                }
                if (test && !cell_may_contain_surface(v, h)) continue;
                kept.push_back(x + n * (y + n * z));
                corners.insert(corners.end(), v, v + 8);
            }
    level->cells = n;
    level->kept = uint32_t(kept.size());
    const uint32_t words = level->words();
    NFD_TRY(level->buffers.make(VkDeviceSize(words) * 4, &level->bits));
    NFD_TRY(level->buffers.make(VkDeviceSize(words) * 4, &level->prefix));
    NFD_TRY(level->buffers.make(VkDeviceSize(kept.size()) * 4, &level->list));
    NFD_TRY(level->buffers.make(VkDeviceSize(corners.size()) * 4, &level->corners));
    uint32_t* bits = level->bits->as<uint32_t>();
    std::memset(bits, 0, size_t(words) * 4);
    for (uint32_t c : kept) bits[c >> 5] |= 1u << (c & 31);
    uint32_t total = 0;
    for (uint32_t w = 0; w < words; ++w) {
        level->prefix->as<uint32_t>()[w] = total;
        total += uint32_t(__builtin_popcount(bits[w]));
    }
    std::memcpy(level->list->data, kept.data(), kept.size() * 4);
    std::memcpy(level->corners->data, corners.data(), corners.size() * 4);
    return NFD_SUCCESS;
}

// What the level kernels bind at 0-6: the parent level and the child grid's new values.
struct ChildGrid {
    Buffer *owned = nullptr, *counts = nullptr, *offsets = nullptr, *points = nullptr,
           *values = nullptr;
    uint32_t count = 0;
};

// Evaluates the new points of the child grids of all kept cells of `parent`.
nfd_result evaluate_child_grids(Device& d, DeviceNetwork& net, const Level& parent,
                                const LevelPush& push, Buffers& buffers, ChildGrid* g) {
    NFD_TRY(buffers.make(VkDeviceSize(parent.kept) * 4, &g->owned));
    NFD_TRY(buffers.make(VkDeviceSize(parent.kept) * 4, &g->counts));
    NFD_TRY(buffers.make(VkDeviceSize(parent.kept) * 4, &g->offsets));
    Buffers scratch(*d.vk);
    NFD_TRY(d.vk->begin());
    NFD_TRY(d.vk->dispatch(d.refine_count,
                           {*parent.bits, *parent.prefix, *parent.list, *parent.corners, *g->owned,
                            *g->offsets, *g->counts /* values: unused */, *g->counts},
                           &push, parent.kept));
    NFD_TRY(record_scan(d, scratch, *g->counts, *g->offsets, parent.kept, false));
    NFD_TRY(d.vk->submit());
    g->count = word(*g->offsets, parent.kept - 1) + word(*g->counts, parent.kept - 1);
    NFD_TRY(buffers.make(VkDeviceSize(g->count) * 12, &g->points));
    NFD_TRY(buffers.make(VkDeviceSize(g->count) * 4, &g->values));
    NFD_TRY(d.vk->begin());
    NFD_TRY(d.vk->dispatch(d.refine_points,
                           {*parent.bits, *parent.prefix, *parent.list, *parent.corners, *g->owned,
                            *g->offsets, *g->values, *g->points},
                           &push, parent.kept));
    NFD_TRY(record_field(d, net, *g->points, *g->values, g->count));
    return NFD_SUCCESS;  // recording: the caller may add work, then submits
}

nfd_result refine_level(Device& d, DeviceNetwork& net, const Level& parent,
                        const LevelPush& push, Level* child, uint64_t* evaluated) {
    Buffers step_buffers(*d.vk);
    ChildGrid g;
    NFD_TRY(evaluate_child_grids(d, net, parent, push, step_buffers, &g));
    *evaluated += g.count;
    child->cells = push.child_cells;
    const uint32_t words = child->words();
    NFD_TRY(child->buffers.make(VkDeviceSize(words) * 4, &child->bits));
    NFD_TRY(child->buffers.make(VkDeviceSize(words) * 4, &child->prefix));
    Buffers scratch(*d.vk);
    d.vk->fill(*child->bits, 0);
    NFD_TRY(d.vk->dispatch(d.refine_cells,
                           {*parent.bits, *parent.prefix, *parent.list, *parent.corners, *g.owned,
                            *g.offsets, *g.values, *child->bits},
                           &push, parent.kept));
    NFD_TRY(record_scan(d, scratch, *child->bits, *child->prefix, words, true));
    NFD_TRY(d.vk->submit());
    child->kept = word(*child->prefix, words - 1) +
                  uint32_t(__builtin_popcount(word(*child->bits, words - 1)));
    NFD_TRY(child->buffers.make(VkDeviceSize(child->kept) * 4, &child->list));
    NFD_TRY(child->buffers.make(VkDeviceSize(child->kept) * 32, &child->corners));
    if (child->kept == 0) return NFD_SUCCESS;
    LevelPush gather = push;
    gather.count = child->kept;
    NFD_TRY(d.vk->begin());
    NFD_TRY(d.vk->dispatch(d.bitmap_compact, {*child->bits, *child->prefix, *child->list}, &words,
                           words));
    NFD_TRY(d.vk->dispatch(d.gather_corners,
                           {*parent.bits, *parent.prefix, *parent.list, *parent.corners, *g.owned,
                            *g.offsets, *g.values, *child->list, *child->corners},
                           &gather, child->kept));
    return d.vk->submit();
}

// Marching cubes on the children of `parent` (level 1), whose child grids `g` holds; releases
// parent.corners and g's buffers on the way.
nfd_result marching_cubes(Device& d, const Level& parent, const LevelPush& push,
                          const ChildGrid& g, MeshData* mesh, ExtractStats* stats) {
    Buffers buffers(*d.vk);
    const uint32_t k = parent.kept;
    if (k >= 1u << 26) return NFD_ERROR_LIMIT_EXCEEDED;  // mc_emit's vertex records: k << 6 | edge
    Buffer *masks, *grids, *vertex_counts, *vertex_offsets, *triangle_counts, *triangle_offsets,
        *active;
    NFD_TRY(buffers.make(VkDeviceSize(k) * 8, &masks));
    NFD_TRY(buffers.make(VkDeviceSize(k) * 27 * 4, &grids));
    NFD_TRY(buffers.make(VkDeviceSize(k) * 4, &vertex_counts));
    NFD_TRY(buffers.make(VkDeviceSize(k) * 4, &vertex_offsets));
    NFD_TRY(buffers.make(VkDeviceSize(k) * 4, &triangle_counts));
    NFD_TRY(buffers.make(VkDeviceSize(k) * 4, &triangle_offsets));
    NFD_TRY(buffers.make(4, &active));
    Buffers scratch(*d.vk);
    NFD_TRY(d.vk->begin());
    d.vk->fill(*active, 0);
    NFD_TRY(d.vk->dispatch(d.mc_classify,
                           {*parent.bits, *parent.prefix, *parent.list, *parent.corners, *g.owned,
                            *g.offsets, *g.values, d.mc_tables, *masks, *grids, *vertex_counts,
                            *triangle_counts, *active},
                           &push, k));
    NFD_TRY(record_scan(d, scratch, *vertex_counts, *vertex_offsets, k, false));
    NFD_TRY(record_scan(d, scratch, *triangle_counts, *triangle_offsets, k, false));
    NFD_TRY(d.vk->submit());
    scratch.release();
    const uint32_t vertices = word(*vertex_offsets, k - 1) + word(*vertex_counts, k - 1);
    const uint32_t triangles = word(*triangle_offsets, k - 1) + word(*triangle_counts, k - 1);
    stats->active_cells = word(*active, 0);
    // mc_emit and mc_vertices read the child grids from `grids`: the sparse storage goes before
    // the mesh buffers are made (peak memory), and its bindings take any live buffer.
    for (Buffer* b : {parent.corners, g.owned, g.offsets, g.values}) d.vk->destroy(*b);

    Buffer *edges, *positions, *normals, *indices;
    NFD_TRY(buffers.make(VkDeviceSize(vertices) * 4, &edges));
    NFD_TRY(buffers.make(VkDeviceSize(vertices) * 12, &positions));
    NFD_TRY(buffers.make(VkDeviceSize(vertices) * 12, &normals));
    NFD_TRY(buffers.make(VkDeviceSize(triangles) * 12, &indices));
    NFD_TRY(d.vk->begin());
    NFD_TRY(d.vk->dispatch(d.mc_emit,
                           {*parent.bits, *parent.prefix, *parent.list, *masks, *masks, *masks,
                            *masks, d.mc_tables, *masks, *grids, *vertex_offsets,
                            *triangle_offsets, *edges, *indices},
                           &push, k));
    LevelPush per_vertex = push;
    per_vertex.count = vertices;
    NFD_TRY(d.vk->dispatch(d.mc_vertices,
                           {*parent.bits, *parent.prefix, *parent.list, *masks, *masks, *masks,
                            *masks, d.mc_tables, *masks, *grids, *edges, *positions, *normals},
                           &per_vertex, vertices));
    NFD_TRY(d.vk->submit());

    try {
        mesh->positions.assign(positions->as<float>(), positions->as<float>() + 3 * size_t(vertices));
        mesh->normals.assign(normals->as<float>(), normals->as<float>() + 3 * size_t(vertices));
        mesh->indices.assign(indices->as<uint32_t>(), indices->as<uint32_t>() + 3 * size_t(triangles));
    } catch (const std::bad_alloc&) {
        return NFD_ERROR_OUT_OF_MEMORY;
    }
    return NFD_SUCCESS;
}

}  // namespace

nfd_result create_device(const nfd_vulkan_device* adopt, bool enable_validation,
                         std::unique_ptr<Device>* out) {
    std::unique_ptr<Device> d(new (std::nothrow) Device());
    if (!d) return NFD_ERROR_OUT_OF_MEMORY;
    NFD_TRY(Context::create(adopt, enable_validation, &d->vk));
    NFD_TRY(create_kernels(*d));
    *out = std::move(d);
    return NFD_SUCCESS;
}

void destroy_device(Device* device) { delete device; }

const char* device_name(const Device& device) { return device.vk->name().c_str(); }

namespace {

// Evaluates n points kEvaluateChunk at a time, handing each chunk's results (a float per point,
// or a vec4 with `gradient`) to take(first point, count, results).
template <class Take>
nfd_result evaluate_in_chunks(Device& device, const Network& network, const float* unit_xyz,
                              size_t n, bool gradient, Take&& take) {
    if (n == 0) return NFD_SUCCESS;
    DeviceNetwork net;
    NFD_TRY(upload_network(device, network, &net));
    Buffers buffers(*device.vk);
    const size_t chunk = std::min(n, kEvaluateChunk);
    Buffer *points, *results;
    NFD_TRY(buffers.make(chunk * 12, &points));
    NFD_TRY(buffers.make(chunk * (gradient ? 16 : 4), &results));
    for (size_t begin = 0; begin < n; begin += chunk) {
        const uint32_t count = uint32_t(std::min(chunk, n - begin));
        std::memcpy(points->data, unit_xyz + 3 * begin, size_t(count) * 12);
        NFD_TRY(device.vk->begin());
        NFD_TRY(record_field(device, net, *points, *results, count, gradient));
        NFD_TRY(device.vk->submit());
        take(begin, count, results->as<float>());
    }
    return NFD_SUCCESS;
}

}  // namespace

nfd_result evaluate(Device& device, const Network& network, const float* unit_xyz, size_t n,
                    float* out) {
    return evaluate_in_chunks(device, network, unit_xyz, n, false,
                              [&](size_t begin, uint32_t count, const float* r) {
                                  std::memcpy(out + begin, r, size_t(count) * 4);
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

nfd_result extract_mesh(Device& device, const Geometry& geometry, uint32_t resolution,
                        MeshData* mesh, ExtractStats* stats) {
    if (resolution < NFD_MIN_RESOLUTION || resolution > NFD_MAX_RESOLUTION)
        return NFD_ERROR_LIMIT_EXCEEDED;
    if (geometry.field != FieldType::Sdf) return NFD_ERROR_UNSUPPORTED_FEATURE;
    ExtractStats st;
    const auto t_field = Clock::now();
    DeviceNetwork net;
    NFD_TRY(upload_network(device, geometry.network, &net));

    const uint32_t levels = refinement_levels(resolution);
    const uint32_t top = std::max(levels, 1u);
    const float step = 2.0f / float(resolution);
    Level level(*device.vk);
    NFD_TRY(top_level(device, net, resolution, top, levels > 0, &level, &st.points_evaluated));

    LevelPush push;
    push.step = step;
    push.scale = geometry.scale;
    for (int a = 0; a < 3; ++a) push.center[a] = geometry.center[a];
    MeshData out;
    for (uint32_t l = top; l-- > 0 && level.kept > 0;) {  // parent level l + 1, children l
        push.parent_cells = level.cells;
        push.child_cells = cells_at_level(resolution, l);
        push.child_level = l;
        push.count = level.kept;
        if (l > 0) {
            push.threshold = kLipschitzMargin * (step * float(1u << l)) * 0.8660254f;
            Level child(*device.vk);
            NFD_TRY(refine_level(device, net, level, push, &child, &st.points_evaluated));
            level = std::move(child);
        } else {
            Buffers grid_buffers(*device.vk);
            ChildGrid g;
            NFD_TRY(evaluate_child_grids(device, net, level, push, grid_buffers, &g));
            NFD_TRY(device.vk->submit());
            st.points_evaluated += g.count;
            device.vk->destroy(*g.points);  // the mesh buffers take their place
            st.seconds_field = seconds_since(t_field);
            const auto t_mesh = Clock::now();
            NFD_TRY(marching_cubes(device, level, push, g, &out, &st));
            st.seconds_mesh = seconds_since(t_mesh);
        }
    }
    if (out.positions.empty()) st.seconds_field = seconds_since(t_field);  // nothing kept
    *mesh = std::move(out);
    if (stats) *stats = st;
    return NFD_SUCCESS;
}

}  // namespace nfd::gpu
