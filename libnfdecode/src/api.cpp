// The C API: argument checks, then the internal calls, inside a guard that turns every exception
// into a result code (nothing may unwind into C callers).
#include <algorithm>
#include <array>
#include <cstdint>
#include <cstring>
#include <exception>
#include <functional>
#include <memory>
#include <mutex>
#include <new>
#include <optional>
#include <stdexcept>
#include <string>
#include <system_error>
#include <vector>

#include "bitstream.h"
#include "colour.h"
#include "export.h"
#include "extract.h"
#include "grid.h"
#include "host_memory.h"
#include "mesh.h"
#include "network.h"
#include "nfdecode/nfdecode.h"
#include "extract_work.h"
#include "options.h"
#include "progressive.h"
#include "queue.h"
#include "sample_points.h"
#include "stream.h"
#include "vdb_module.h"
#if NFD_WITH_VULKAN
#include "gpu/gpu_decode.h"
#endif

struct nfd_context : nfd::HostAllocated {
    nfd_device_kind kind = NFD_DEVICE_CPU;
    std::string name = "cpu";
    std::string reason;  // nfd_context_device_reason
    unsigned cpu_threads = 0;
#if NFD_WITH_VULKAN
    std::unique_ptr<nfd::gpu::Device> gpu;
#endif
};

struct nfd_asset : nfd::HostAllocated {
    nfd::ParsedFile file;
};

struct nfd_stream : nfd::HostAllocated {
    nfd::StreamReader reader;
    bool asset_taken = false, complete_asset_taken = false;
    nfd_context* prepare_context = nullptr;  // until it has been asked to prepare (options)
};

struct nfd_mesh : nfd::HostAllocated {
    nfd::MeshData data;
    nfd::ExtractStats stats;
};

// The ladder (nfdecode.h) is the grid's levels coarsest first: ladder index i is grid level
// `top - i`. A failed step leaves the implementation mid-level: only destroy is allowed after it.
struct nfd_extraction : nfd::HostAllocated {
    std::unique_ptr<nfd::Extraction> impl;
    nfd_context* context = nullptr;
    std::array<double, 3> offset{};  // the asset's, for each mesh (Geometry::offset)
    std::optional<nfd::ColourField> colour;  // colours each mesh unless skip_colour
    uint32_t top = 0;
    bool done = false, failed = false;
};

struct nfd_recording : nfd::HostAllocated {
#if NFD_WITH_VULKAN
    std::unique_ptr<nfd::gpu::Recording> impl;
#endif
    std::array<double, 3> offset{};
};

struct nfd_queue : nfd::HostAllocated {
    nfd_context* context;
    std::unique_ptr<nfd::Queue> queue;
};

struct nfd_job : nfd::HostAllocated {
    std::shared_ptr<nfd::Job> job;
    uint32_t levels_total = 0, final_resolution = 0;
    std::array<double, 3> offset{};  // set before the job starts: its meshes come after
    // What the job decodes: the options read once at submission.
    struct Request {
        nfd_mesh_options mesh;
        nfd_job_options job;
        uint32_t resolution, top, mask;  // mask: grid levels to mesh
    };
    // A job of nfd_queue_submit_stream: its stream, fed on the caller's threads under `mutex`,
    // and what its work is made of once the stream holds the asset.
    struct Input {
        std::mutex mutex;
        std::unique_ptr<nfd_stream> stream;
        nfd_context* context = nullptr;
        Request request{};
        bool started = false;  // the work was made (or the job ended before it was)
    };
    std::unique_ptr<Input> input;
};

// The finest level in the public layout, built once so that nfd_grid_get_voxels hands out stable
// pointers, and what the VDB metadata needs of the asset, which the grid may outlive.
struct nfd_grid : nfd::HostAllocated {
    nfd::vector<int32_t> ijk;
    nfd::vector<float> values;   // original units
    nfd::vector<float> colours;  // rgb per voxel, or empty
    nfd_grid_voxels voxels{};   // points into ijk and values
    std::array<double, 3> offset{};  // original = offset + voxel position
    uint32_t format_major = 0, format_minor = 0;
};

namespace {

// What an asset's outputs are placed relative to (Geometry::offset).
std::array<double, 3> offset_of(const nfd::Geometry& g) { return {g.offset(0), g.offset(1), g.offset(2)}; }

template <class Fn>
nfd_result guarded(Fn&& fn) noexcept {
    try {
        return fn();
    } catch (const std::bad_alloc&) {
        return NFD_ERROR_OUT_OF_MEMORY;
    } catch (const std::length_error&) {  // a size beyond what the allocator can even express
        return NFD_ERROR_OUT_OF_MEMORY;
    } catch (...) {
        return NFD_ERROR_INTERNAL;
    }
}

// Maps original-frame points to the unit frame in bounded blocks (colour.h) and calls
// fn(unit_xyz, n, first point index) on each block, inside the exception guard.
template <class Fn>
nfd_result evaluate_in_blocks(const nfd_asset& asset, const float* points, size_t count, Fn&& fn) {
    return guarded([&] {
        const nfd::Geometry& g = asset.file.geometry;
        const float center[3] = {g.emit_center(0), g.emit_center(1), g.emit_center(2)};
        return nfd::for_each_unit_block(center, g.scale, points, count, fn);
    });
}

// The context's Vulkan device, or null for the CPU path.
nfd::gpu::Device* device_of(const nfd_context& context) {
#if NFD_WITH_VULKAN
    return context.gpu.get();
#else
    (void)context;
    return nullptr;
#endif
}

// The grid's colour at every voxel, from its indices (unit vertex i is -1 + i * step), in blocks
// so that a grid of 17M voxels at 1024 holds one block of unit positions at a time.
nfd_result colour_voxels(const nfd::ColourField& colour, float step, nfd_context& context,
                         nfd_grid* grid) {
    constexpr size_t kBlock = size_t(1) << 20;
    const size_t count = grid->values.size();
    nfd::vector<float> rgb(3 * count), unit(3 * std::min(count, kBlock));
    for (size_t begin = 0; begin < count; begin += kBlock) {
        const size_t n = std::min(kBlock, count - begin);
        for (size_t i = 0; i < 3 * n; ++i) unit[i] = -1.0f + float(grid->ijk[3 * begin + i]) * step;
        const nfd_result r = nfd::evaluate_colour_unit(colour.network, unit.data(), n,
                                                       device_of(context), context.cpu_threads,
                                                       rgb.data() + 3 * begin);
        if (r != NFD_SUCCESS) return r;
    }
    grid->colours = std::move(rgb);
    return NFD_SUCCESS;
}

// nfd_grid_voxels of a grid's finest level: indices, distances in original units, transform.
// The other levels and the cell lists are freed before the copy (the bunny at 1024: peak RSS
// 435 MB instead of 511 MB).
std::unique_ptr<nfd_grid> finest_voxels(nfd::SparseGrid&& sparse, const nfd::ParsedFile& file) {
    const nfd::Geometry& g = file.geometry;
    const float step = sparse.step;
    const uint32_t resolution = sparse.resolution;
    nfd::GridLevel finest = std::move(sparse.levels.front());
    sparse = nfd::SparseGrid();
    finest.cells = nfd::vector<uint32_t>();

    auto grid = std::make_unique<nfd_grid>();
    grid->ijk.resize(3 * size_t(finest.vertices.size()));
    grid->values.resize(finest.vertices.size());
    finest.vertices.for_each([&](uint32_t rank, uint32_t x, uint32_t y, uint32_t z) {
        int32_t* ijk = &grid->ijk[3 * size_t(rank)];
        ijk[0] = int32_t(x);
        ijk[1] = int32_t(y);
        ijk[2] = int32_t(z);
        grid->values[rank] = finest.values[rank] * g.scale;
    });
    nfd_grid_voxels& v = grid->voxels;
    v.ijk = grid->ijk.data();
    v.values = grid->values.data();
    v.count = grid->values.size();
    v.voxel_size = step * g.scale;  // unit vertex i is -1 + i * step
    for (int a = 0; a < 3; ++a) v.origin[a] = g.emit_center(a) - g.scale;
    grid->offset = offset_of(g);
    v.background = g.truncation * g.scale;
    v.resolution = resolution;
    v.field_type = g.field == nfd::FieldType::Sdf ? NFD_FIELD_SDF : NFD_FIELD_UDF;
    grid->format_major = file.major;
    grid->format_minor = file.minor;
    return grid;
}

// Runs queue work to its end on the calling thread and takes its final mesh (nfd_mesh_extract
// with memory limits).
nfd_result run_bounded(nfd::ExtractWork&& work, nfd::MeshData* mesh, nfd::ExtractStats* stats) {
    nfd::StepResult step;
    while (!step.finished) {
        step = nfd::StepResult{};
        const nfd_result r = work.step(&step);
        if (r != NFD_SUCCESS) return r;
    }
    if (!step.mesh) return NFD_ERROR_INTERNAL;  // the finest level is always meshed
    *mesh = std::move(step.mesh->data);
    *stats = step.mesh->stats;
    return NFD_SUCCESS;
}

// A C caller may store any int in an enum field, which C++ may not even load as the enum type:
// read the bytes as an int so that the range check itself is defined.
bool is_device_kind(const nfd_device_kind& k) {
    static_assert(sizeof(nfd_device_kind) == sizeof(int), "C enums are int-sized");
    int v;
    std::memcpy(&v, &k, sizeof v);
    return v == NFD_DEVICE_AUTO || v == NFD_DEVICE_VULKAN || v == NFD_DEVICE_CPU;
}

// The first sized layouts (0.2): where their last 0.2 field ends. Fields appended later lie past.
template <class T, class Field>
constexpr size_t layout_end(Field T::*, size_t offset) { return offset + sizeof(Field); }
#define NFD_LAYOUT_END(T, field) layout_end(&T::field, offsetof(T, field))
constexpr size_t kContextOptions02 = NFD_LAYOUT_END(nfd_context_options, enable_validation);
constexpr size_t kMeshOptions02 = NFD_LAYOUT_END(nfd_mesh_options, resolution);
constexpr size_t kGridOptions02 = NFD_LAYOUT_END(nfd_grid_options, resolution);
constexpr size_t kStreamOptions02 = NFD_LAYOUT_END(nfd_stream_options, struct_size);
constexpr size_t kExtractionOptions02 = NFD_LAYOUT_END(nfd_extraction_options, mesh_levels);
constexpr size_t kExtractionLevel02 = NFD_LAYOUT_END(nfd_extraction_level, next_device_bytes);
constexpr size_t kQueueOptions02 = NFD_LAYOUT_END(nfd_queue_options, device_budget_bytes);
constexpr size_t kJobOptions02 = NFD_LAYOUT_END(nfd_job_options, user_data);
constexpr size_t kJobProgress1 = NFD_LAYOUT_END(nfd_job_progress, final_resolution);
constexpr size_t kRecordingOptions03 = NFD_LAYOUT_END(nfd_recording_options, max_triangles);
constexpr size_t kRecordingResult03 = NFD_LAYOUT_END(nfd_recording_result, stats);

// The grid resolution an option asks for (0 = NFD_DEFAULT_RESOLUTION), or 0 outside the caps.
uint32_t options_resolution(uint32_t requested) {
    const uint32_t r = requested ? requested : NFD_DEFAULT_RESOLUTION;
    return r >= NFD_MIN_RESOLUTION && r <= NFD_MAX_RESOLUTION ? r : 0;
}

nfd_stream_progress progress_of(const nfd_stream& stream) {
    const nfd::FileParser& parser = stream.reader.parser();
    nfd_stream_progress p{};
    p.bytes_consumed = stream.reader.bytes_consumed();
    p.chunks_complete = parser.chunks_read();
    if (parser.header_read()) {
        p.file_size = parser.file().file_size;
        p.format_major = parser.file().major;
        p.format_minor = parser.file().minor;
        p.flags |= NFD_STREAM_HEADER_READ;
    }
    if (parser.geometry_read()) p.flags |= NFD_STREAM_GEOMETRY_READY;
    if (parser.file().has_colour()) p.flags |= NFD_STREAM_COLOUR_SEEN;
    if (parser.complete()) p.flags |= NFD_STREAM_COMPLETE;
    return p;
}

// A ladder mask of a resolution whose ladder has top + 1 levels: it must hold the final level and
// no bit past it (0 is each caller's default).
bool valid_ladder_mask(uint32_t ladder_mask, uint32_t top) {
    return !ladder_mask || ((ladder_mask >> top) == 1u);
}

// Ladder mask bit i (0 = coarsest) -> grid level top - i; 0 = every level.
uint32_t grid_level_mask(uint32_t ladder_mask, uint32_t top) {
    if (!ladder_mask) return (2u << top) - 1;
    uint32_t mask = 0;
    for (uint32_t i = 0; i <= top; ++i)
        if (ladder_mask >> i & 1) mask |= 1u << (top - i);
    return mask;
}

nfd_decode_stats public_stats(const nfd::ExtractStats& s) {
    nfd_decode_stats out{};
    out.seconds_field = s.seconds_field;
    out.seconds_mesh = s.seconds_mesh;
    out.points_evaluated = s.points_evaluated;
    out.active_cells = s.active_cells;
    return out;
}

// Writes the fields of `info` that the caller's struct_size covers (0: the first layout).
void write_level_info(const nfd_extraction_level& info, nfd_extraction_level* out) {
    const size_t size = out->struct_size ? out->struct_size : kExtractionLevel02;
    const uint32_t caller_size = out->struct_size;
    std::memcpy(out, &info, std::min(size, sizeof info));
    out->struct_size = caller_size;
}

}  // namespace

extern "C" {

const char* nfd_result_string(nfd_result result) {
    switch (result) {
        case NFD_SUCCESS: return "success";
        case NFD_ERROR_TRUNCATED: return "truncated input: fewer bytes than announced";
        case NFD_ERROR_CORRUPT: return "corrupt input: bad magic, checksum, value or size";
        case NFD_ERROR_UNSUPPORTED_VERSION: return "unsupported format version (other major)";
        case NFD_ERROR_UNSUPPORTED_FEATURE: return "unsupported feature in this build or version";
        case NFD_ERROR_INVALID_ARGUMENT: return "invalid argument";
        case NFD_ERROR_LIMIT_EXCEEDED: return "request exceeds a documented limit";
        case NFD_ERROR_CANCELLED: return "the job was cancelled";
        case NFD_ERROR_NOT_READY: return "the job has no result yet";
        case NFD_ERROR_CAPACITY_EXCEEDED:
            return "the recorded decode outgrew its capacities (record again with the needed ones)";
        case NFD_ERROR_NO_COLOUR: return "the asset has no colour";
        case NFD_ERROR_OUT_OF_MEMORY: return "out of memory";
        case NFD_ERROR_DEVICE_UNAVAILABLE: return "no usable Vulkan device";
        case NFD_ERROR_DEVICE: return "Vulkan device error";
        case NFD_ERROR_IO: return "file could not be written";
        case NFD_ERROR_INTERNAL: return "internal error in libnfdecode";
    }
    return "unknown result";
}

// The header and the CMake project (the package version engines find) must not drift apart.
static_assert(NFD_VERSION == NFD_MAKE_VERSION(NFD_PACKAGE_VERSION_MAJOR, NFD_PACKAGE_VERSION_MINOR,
                                              NFD_PACKAGE_VERSION_PATCH),
              "nfdecode.h vs CMakeLists.txt");
uint32_t nfd_version(void) { return NFD_VERSION; }

nfd_result nfd_set_allocator(const nfd_allocator* allocator) {
    return nfd::set_host_allocator(allocator);
}

nfd_result nfd_context_create(const nfd_context_options* options, nfd_context** out_context) {
    if (!out_context) return NFD_ERROR_INVALID_ARGUMENT;
    *out_context = nullptr;
    nfd_context_options opts;
    if (nfd::read_options(options, kContextOptions02, &opts) != NFD_SUCCESS)
        return NFD_ERROR_INVALID_ARGUMENT;
    if (!is_device_kind(opts.device)) return NFD_ERROR_INVALID_ARGUMENT;
    if (opts.adopt && opts.device == NFD_DEVICE_CPU) return NFD_ERROR_INVALID_ARGUMENT;
    return guarded([&] {
        auto ctx = std::make_unique<nfd_context>();
        ctx->cpu_threads = opts.cpu_threads;
        ctx->reason = opts.device == NFD_DEVICE_CPU ? "requested" : "auto: no Vulkan device";
        if (opts.device != NFD_DEVICE_CPU) {
#if NFD_WITH_VULKAN
            // AUTO without a device to adopt takes a hardware GPU only: on a CPU implementation
            // (lavapipe) the C++ path decodes faster (bench/RESULTS.md, "Decode speed").
            const bool automatic = opts.device == NFD_DEVICE_AUTO && !opts.adopt;
            std::string declined;
            const nfd_result r = nfd::gpu::create_device(
                opts.adopt, opts.enable_validation != 0, &ctx->gpu, automatic, &declined,
                opts.pipeline_cache, opts.pipeline_cache_size);
            if (r == NFD_SUCCESS) {
                nfd::gpu::set_host_threads(*ctx->gpu, opts.cpu_threads);
                ctx->kind = NFD_DEVICE_VULKAN;
                ctx->name = nfd::gpu::device_name(*ctx->gpu);
                ctx->reason = opts.adopt ? "adopted" : automatic ? "auto: a GPU" : "requested";
            } else {
                // AUTO falls back to the CPU when no device can be made; an adopted device that
                // fails, or an explicit VULKAN request, reports why instead.
                ctx->gpu.reset();
                if (!automatic || (r != NFD_ERROR_DEVICE_UNAVAILABLE && r != NFD_ERROR_DEVICE))
                    return r;
                if (!declined.empty()) ctx->reason = "auto: " + declined;
            }
#else
            if (opts.device == NFD_DEVICE_VULKAN || opts.adopt) return NFD_ERROR_DEVICE_UNAVAILABLE;
#endif
        }
        *out_context = ctx.release();
        return NFD_SUCCESS;
    });
}

void nfd_context_destroy(nfd_context* context) { delete context; }

nfd_result nfd_context_get_pipeline_cache(const nfd_context* context, void* data,
                                          size_t* size) {
    if (!context || !size) return NFD_ERROR_INVALID_ARGUMENT;
    return guarded([&] {
        std::vector<uint8_t> bytes;
#if NFD_WITH_VULKAN
        if (context->gpu)
            if (const nfd_result r = nfd::gpu::pipeline_cache(*context->gpu, &bytes); r != NFD_SUCCESS)
                return r;
#endif
        const size_t capacity = *size;
        *size = bytes.size();
        if (!data) return NFD_SUCCESS;
        if (bytes.size() > capacity) return NFD_ERROR_LIMIT_EXCEEDED;
        if (!bytes.empty()) std::memcpy(data, bytes.data(), bytes.size());
        return NFD_SUCCESS;
    });
}

nfd_device_kind nfd_context_device_kind(const nfd_context* context) {
    return context ? context->kind : NFD_DEVICE_AUTO;
}

const char* nfd_context_device_name(const nfd_context* context) {
    return context ? context->name.c_str() : "";
}

const char* nfd_context_device_reason(const nfd_context* context) {
    return context ? context->reason.c_str() : "";
}

nfd_result nfd_context_get_device_memory(const nfd_context* context, nfd_device_memory* out) {
    if (!context || !out) return NFD_ERROR_INVALID_ARGUMENT;
    if (out->struct_size && out->struct_size < sizeof(nfd_device_memory))
        return NFD_ERROR_INVALID_ARGUMENT;
    nfd_device_memory memory{};
    memory.struct_size = out->struct_size;
#if NFD_WITH_VULKAN
    if (context->gpu) {
        const nfd::gpu::DeviceMemory m = nfd::gpu::device_memory(*context->gpu);
        memory.live_bytes = m.live;
        memory.live_allocations = m.live_allocations;
        memory.buffers_created = m.buffers;
        memory.allocations_made = m.allocations;
    }
#endif
    *out = memory;
    return NFD_SUCCESS;
}

nfd_result nfd_asset_create(const void* bytes, size_t size, nfd_asset** out_asset) {
    if (!out_asset) return NFD_ERROR_INVALID_ARGUMENT;
    *out_asset = nullptr;
    if (!bytes) return NFD_ERROR_INVALID_ARGUMENT;
    return guarded([&] {
        auto asset = std::make_unique<nfd_asset>();
        const nfd_result r =
            nfd::parse_file(static_cast<const uint8_t*>(bytes), size, &asset->file);
        if (r == NFD_SUCCESS) *out_asset = asset.release();
        return r;
    });
}

void nfd_asset_destroy(nfd_asset* asset) { delete asset; }

nfd_result nfd_asset_get_info(const nfd_asset* asset, nfd_asset_info* out_info) {
    if (!asset || !out_info) return NFD_ERROR_INVALID_ARGUMENT;
    const nfd::ParsedFile& f = asset->file;
    const nfd::Geometry& g = f.geometry;
    nfd_asset_info info{};
    info.format_major = f.major;
    info.format_minor = f.minor;
    info.file_size = f.file_size;
    info.field_type = g.field == nfd::FieldType::Sdf ? NFD_FIELD_SDF : NFD_FIELD_UDF;
    info.truncation = g.truncation;
    std::copy(g.center, g.center + 3, info.center);
    info.scale = g.scale;
    info.num_frequencies = uint32_t(g.network.frequencies.size());
    info.num_layers = uint32_t(g.network.layers.size());
    for (size_t i = 0; i < g.network.layers.size(); ++i) {
        const nfd::Layer& layer = g.network.layers[i];
        info.layer_widths[i] = layer.out;
        info.parameter_count += layer.in * layer.out + layer.out;
    }
    info.bits = g.network.bits;
    info.has_colour = f.has_colour() ? 1 : 0;
    *out_info = info;
    return NFD_SUCCESS;
}

nfd_result nfd_asset_get_frame(const nfd_asset* asset, nfd_asset_frame* out_frame) {
    if (!asset || !out_frame) return NFD_ERROR_INVALID_ARGUMENT;
    if (out_frame->struct_size && out_frame->struct_size < sizeof(nfd_asset_frame))
        return NFD_ERROR_INVALID_ARGUMENT;
    const nfd::Geometry& g = asset->file.geometry;
    nfd_asset_frame frame{};
    frame.struct_size = out_frame->struct_size;
    frame.exact64 = g.frame64 ? 1 : 0;
    for (int a = 0; a < 3; ++a) {
        frame.center[a] = g.frame64 ? g.frame64->center[a] : double(g.center[a]);
        frame.offset[a] = g.offset(a);
    }
    frame.scale = g.frame64 ? g.frame64->scale : double(g.scale);
    *out_frame = frame;
    return NFD_SUCCESS;
}

nfd_result nfd_stream_create(const nfd_stream_options* options, nfd_stream** out_stream) {
    if (!out_stream) return NFD_ERROR_INVALID_ARGUMENT;
    *out_stream = nullptr;
    nfd_stream_options opts;
    if (nfd::read_options(options, kStreamOptions02, &opts) != NFD_SUCCESS)
        return NFD_ERROR_INVALID_ARGUMENT;
    return guarded([&] {
        *out_stream = new nfd_stream();
        (*out_stream)->prepare_context = opts.prepare_context;
        return NFD_SUCCESS;
    });
}

}  // extern "C"

// Helpers between the C entry points are C++ functions: outside the extern "C" block.
namespace {

// nfd_stream_options.prepare_context: once the stream has read GEOM's network shape ahead of the
// chunk, its context compiles that shape's pipelines while the weights arrive.
void prepare_from_stream(nfd_stream& stream) {
    const nfd::Network* shape = stream.reader.early_network_shape();
    if (!stream.prepare_context || !shape || stream.reader.error() != NFD_SUCCESS) return;
#if NFD_WITH_VULKAN
    if (stream.prepare_context->gpu)
        nfd::gpu::warm_field_pipelines(*stream.prepare_context->gpu, *shape,
                                       shape->output == nfd::OutputActivation::Abs
                                           ? nfd::FieldType::Udf
                                           : nfd::FieldType::Sdf);
#endif
    stream.prepare_context = nullptr;
}

}  // namespace

extern "C" {

void nfd_stream_destroy(nfd_stream* stream) { delete stream; }

nfd_result nfd_stream_feed(nfd_stream* stream, const void* bytes, size_t size,
                           nfd_stream_progress* out_progress) {
    if (!stream) return NFD_ERROR_INVALID_ARGUMENT;
    nfd_result r = NFD_ERROR_INVALID_ARGUMENT;  // bytes NULL with a size: the stream is unchanged
    if (bytes || size == 0) {
        r = guarded([&] { return stream->reader.feed(static_cast<const uint8_t*>(bytes), size); });
        stream->reader.record_failure(r);
        prepare_from_stream(*stream);
    }
    if (out_progress) *out_progress = progress_of(*stream);
    return r;
}

nfd_result nfd_stream_finish(nfd_stream* stream) {
    return stream ? stream->reader.finish() : NFD_ERROR_INVALID_ARGUMENT;
}

nfd_result nfd_stream_take_asset(nfd_stream* stream, nfd_asset** out_asset) {
    if (!out_asset) return NFD_ERROR_INVALID_ARGUMENT;
    *out_asset = nullptr;
    if (!stream) return NFD_ERROR_INVALID_ARGUMENT;
    if (stream->reader.error() != NFD_SUCCESS) return stream->reader.error();
    if (!stream->reader.parser().geometry_read() || stream->asset_taken ||
        stream->complete_asset_taken)  // the geometry went with the complete asset
        return NFD_ERROR_INVALID_ARGUMENT;
    return guarded([&] {
        // A copy: the parser keeps the geometry for the complete asset, and goes on with the
        // chunks after GEOM.
        auto asset = std::make_unique<nfd_asset>();
        asset->file = stream->reader.parser().file();
        stream->asset_taken = true;
        *out_asset = asset.release();
        return NFD_SUCCESS;
    });
}

nfd_result nfd_stream_take_complete_asset(nfd_stream* stream, nfd_asset** out_asset) {
    if (!out_asset) return NFD_ERROR_INVALID_ARGUMENT;
    *out_asset = nullptr;
    if (!stream) return NFD_ERROR_INVALID_ARGUMENT;
    if (stream->reader.error() != NFD_SUCCESS) return stream->reader.error();
    if (!stream->reader.parser().complete() || stream->complete_asset_taken)
        return NFD_ERROR_INVALID_ARGUMENT;
    return guarded([&] {
        auto asset = std::make_unique<nfd_asset>();
        asset->file = std::move(stream->reader.parser().file());
        stream->complete_asset_taken = true;
        *out_asset = asset.release();
        return NFD_SUCCESS;
    });
}

nfd_result nfd_peek_format_version(const void* bytes, size_t size, uint32_t* out_major,
                                   uint32_t* out_minor) {
    if (!bytes || !out_major || !out_minor) return NFD_ERROR_INVALID_ARGUMENT;
    if (size < nfd::kHeaderSize) return NFD_ERROR_TRUNCATED;
    return nfd::read_format_version(static_cast<const uint8_t*>(bytes), out_major, out_minor);
}

nfd_result nfd_asset_evaluate(nfd_context* context, const nfd_asset* asset, const float* points,
                              size_t count, float* out_values) {
    if (!context || !asset) return NFD_ERROR_INVALID_ARGUMENT;
    if (count == 0) return NFD_SUCCESS;
    if (!points || !out_values) return NFD_ERROR_INVALID_ARGUMENT;
    return evaluate_in_blocks(*asset, points, count, [&](const float* unit, size_t n, size_t begin) {
#if NFD_WITH_VULKAN
        if (context->gpu)
            return nfd::gpu::evaluate(*context->gpu, asset->file.geometry.network, unit, n,
                                      out_values + begin);
#endif
        nfd::evaluate_cpu(asset->file.geometry.network, unit, n, out_values + begin,
                          context->cpu_threads);
        return NFD_SUCCESS;
    });
}

nfd_result nfd_asset_evaluate_gradient(nfd_context* context, const nfd_asset* asset,
                                       const float* points, size_t count, float* out_values,
                                       float* out_gradients) {
    if (!context || !asset) return NFD_ERROR_INVALID_ARGUMENT;
    if (count == 0) return NFD_SUCCESS;
    if (!points || !out_values || !out_gradients) return NFD_ERROR_INVALID_ARGUMENT;
    return evaluate_in_blocks(*asset, points, count, [&](const float* unit, size_t n, size_t begin) {
#if NFD_WITH_VULKAN
        if (context->gpu)
            return nfd::gpu::evaluate_gradient(*context->gpu, asset->file.geometry.network, unit,
                                               n, out_values + begin, out_gradients + 3 * begin);
#endif
        nfd::evaluate_gradient_cpu(asset->file.geometry.network, unit, n, out_values + begin,
                                   out_gradients + 3 * begin, context->cpu_threads);
        return NFD_SUCCESS;
    });
}

nfd_result nfd_asset_evaluate_colour(nfd_context* context, const nfd_asset* asset,
                                     const float* points, size_t count, float* out_rgb) {
    if (!context || !asset) return NFD_ERROR_INVALID_ARGUMENT;
    if (!asset->file.has_colour()) return NFD_ERROR_NO_COLOUR;
    if (count == 0) return NFD_SUCCESS;
    if (!points || !out_rgb) return NFD_ERROR_INVALID_ARGUMENT;
    return evaluate_in_blocks(*asset, points, count, [&](const float* unit, size_t n, size_t begin) {
        return nfd::evaluate_colour_unit(*asset->file.colour, unit, n, device_of(*context),
                                         context->cpu_threads, out_rgb + 3 * begin);
    });
}

nfd_result nfd_mesh_extract(nfd_context* context, const nfd_asset* asset,
                            const nfd_mesh_options* options, nfd_mesh** out_mesh) {
    if (!out_mesh) return NFD_ERROR_INVALID_ARGUMENT;
    *out_mesh = nullptr;
    if (!context || !asset) return NFD_ERROR_INVALID_ARGUMENT;
    nfd_mesh_options opts;
    if (nfd::read_options(options, kMeshOptions02, &opts) != NFD_SUCCESS)
        return NFD_ERROR_INVALID_ARGUMENT;
    const uint32_t resolution = options_resolution(opts.resolution);
    if (!resolution) return NFD_ERROR_LIMIT_EXCEEDED;
    const nfd::Geometry& g = asset->file.geometry;
    const nfd::MemoryBytes limit{opts.max_host_bytes, opts.max_device_bytes};
    return guarded([&] {
        auto mesh = std::make_unique<nfd_mesh>();
        nfd_result r;
        const std::optional<nfd::ColourField> colour =
            nfd::colour_field(asset->file, opts.skip_colour != 0);
        if (limit.host || limit.device) {
            // Limited: level by level as a queue job runs, each step's bound checked first.
            r = run_bounded(nfd::ExtractWork(g, colour, resolution, 1u, device_of(*context),
                                             context->cpu_threads, limit, opts.sample_band != 0),
                            &mesh->data, &mesh->stats);
        } else {
#if NFD_WITH_VULKAN
            if (context->gpu)
                r = nfd::gpu::extract_mesh(*context->gpu, g, resolution, &mesh->data, &mesh->stats,
                                           opts.sample_band != 0);
            else
#endif
                r = nfd::extract_mesh_cpu(g, resolution, &mesh->data, &mesh->stats,
                                          context->cpu_threads, opts.sample_band != 0);
            if (r == NFD_SUCCESS && colour)
                r = nfd::colour_mesh(*colour, device_of(*context), context->cpu_threads, &mesh->data);
        }
        mesh->data.offset = offset_of(g);
        if (r == NFD_SUCCESS) *out_mesh = mesh.release();
        return r;
    });
}

void nfd_mesh_destroy(nfd_mesh* mesh) { delete mesh; }

nfd_result nfd_mesh_get_data(const nfd_mesh* mesh, nfd_mesh_data* out_data) {
    if (!mesh || !out_data) return NFD_ERROR_INVALID_ARGUMENT;
    out_data->positions = mesh->data.positions.data();
    out_data->normals = mesh->data.normals.data();
    out_data->indices = mesh->data.indices.data();
    out_data->vertex_count = mesh->data.vertex_count();
    out_data->triangle_count = mesh->data.triangle_count();
    return NFD_SUCCESS;
}

nfd_result nfd_mesh_get_colours(const nfd_mesh* mesh, const float** out_colours) {
    if (!mesh || !out_colours) return NFD_ERROR_INVALID_ARGUMENT;
    *out_colours = mesh->data.colours.empty() ? nullptr : mesh->data.colours.data();
    return NFD_SUCCESS;
}

nfd_result nfd_mesh_evaluate_colours(nfd_context* context, const nfd_asset* asset,
                                     nfd_mesh* mesh) {
    if (!context || !asset || !mesh) return NFD_ERROR_INVALID_ARGUMENT;
    const std::optional<nfd::ColourField> colour = nfd::colour_field(asset->file);
    if (!colour) return NFD_ERROR_NO_COLOUR;
    return guarded([&] {
        return nfd::colour_mesh(*colour, device_of(*context), context->cpu_threads, &mesh->data);
    });
}

nfd_result nfd_mesh_get_stats(const nfd_mesh* mesh, nfd_decode_stats* out_stats) {
    if (!mesh || !out_stats) return NFD_ERROR_INVALID_ARGUMENT;
    *out_stats = public_stats(mesh->stats);
    return NFD_SUCCESS;
}

nfd_result nfd_mesh_sample_points(const nfd_mesh* mesh, size_t count, uint64_t seed,
                                  float* out_points, float* out_normals) {
    if (!mesh) return NFD_ERROR_INVALID_ARGUMENT;
    if (count == 0) return NFD_SUCCESS;
    if (!out_points || mesh->data.triangle_count() == 0) return NFD_ERROR_INVALID_ARGUMENT;
    return guarded([&] {
        nfd::sample_points(mesh->data, count, seed, out_points, out_normals);
        return NFD_SUCCESS;
    });
}

nfd_result nfd_mesh_write_glb(const nfd_mesh* mesh, const char* path) {
    if (!mesh || !path) return NFD_ERROR_INVALID_ARGUMENT;
    return guarded([&] { return nfd::write_glb(mesh->data, path); });
}

nfd_result nfd_mesh_write_ply(const nfd_mesh* mesh, const char* path) {
    if (!mesh || !path) return NFD_ERROR_INVALID_ARGUMENT;
    return guarded([&] { return nfd::write_mesh_ply(mesh->data, path); });
}

nfd_result nfd_points_write_ply(const float* points, const float* normals, size_t count,
                                const char* path) {
    return nfd_points_write_placed_ply(points, normals, nullptr, count, nullptr, path);
}

nfd_result nfd_points_write_coloured_ply(const float* points, const float* normals,
                                         const float* colours, size_t count, const char* path) {
    return nfd_points_write_placed_ply(points, normals, colours, count, nullptr, path);
}

nfd_result nfd_points_write_placed_ply(const float* points, const float* normals,
                                       const float* colours, size_t count, const double* offset,
                                       const char* path) {
    if (!path || (count > 0 && !points)) return NFD_ERROR_INVALID_ARGUMENT;
    std::array<double, 3> placed{};
    if (offset) std::copy(offset, offset + 3, placed.begin());
    return guarded([&] { return nfd::write_points_ply(points, normals, colours, count, placed, path); });
}

nfd_result nfd_mesh_get_offset(const nfd_mesh* mesh, double* out_offset) {
    if (!mesh || !out_offset) return NFD_ERROR_INVALID_ARGUMENT;
    std::copy(mesh->data.offset.begin(), mesh->data.offset.end(), out_offset);
    return NFD_SUCCESS;
}

nfd_result nfd_extraction_ladder(uint32_t resolution, uint32_t* out_resolutions, uint32_t capacity,
                                 uint32_t* out_count) {
    if (!out_count || (capacity > 0 && !out_resolutions)) return NFD_ERROR_INVALID_ARGUMENT;
    const uint32_t r = options_resolution(resolution);
    if (!r) return NFD_ERROR_LIMIT_EXCEEDED;
    const uint32_t top = nfd::refinement_levels(r);
    static_assert(NFD_MAX_RESOLUTION / 32 < 1u << NFD_MAX_LADDER_LEVELS, "the ladder's cap");
    *out_count = top + 1;
    for (uint32_t i = 0; i <= top && i < capacity; ++i)
        out_resolutions[i] = nfd::cells_at_level(r, top - i);
    return capacity > top ? NFD_SUCCESS : NFD_ERROR_INVALID_ARGUMENT;
}

nfd_result nfd_extraction_create(nfd_context* context, const nfd_asset* asset,
                                 const nfd_extraction_options* options,
                                 nfd_extraction** out_extraction) {
    if (!out_extraction) return NFD_ERROR_INVALID_ARGUMENT;
    *out_extraction = nullptr;
    if (!context || !asset) return NFD_ERROR_INVALID_ARGUMENT;
    nfd_extraction_options opts;
    if (nfd::read_options(options, kExtractionOptions02, &opts) != NFD_SUCCESS)
        return NFD_ERROR_INVALID_ARGUMENT;
    const uint32_t resolution = options_resolution(opts.resolution);
    if (!resolution) return NFD_ERROR_LIMIT_EXCEEDED;
    const uint32_t top = nfd::refinement_levels(resolution);
    if (!valid_ladder_mask(opts.mesh_levels, top)) return NFD_ERROR_INVALID_ARGUMENT;
    const uint32_t mask = grid_level_mask(opts.mesh_levels, top);
    const nfd::Geometry& g = asset->file.geometry;
    return guarded([&] {
        auto extraction = std::make_unique<nfd_extraction>();
        extraction->top = top;
        extraction->context = context;
        extraction->offset = offset_of(g);
        extraction->colour = nfd::colour_field(asset->file, opts.skip_colour != 0);
#if NFD_WITH_VULKAN
        if (context->gpu) {
            const nfd_result r =
                nfd::gpu::make_extraction(*context->gpu, g, resolution, mask,
                                          opts.sample_band != 0, &extraction->impl);
            if (r != NFD_SUCCESS) return r;
        } else
#endif
            extraction->impl =
                nfd::make_extraction_cpu(g, resolution, mask, context->cpu_threads,
                                         opts.sample_band != 0);
        *out_extraction = extraction.release();
        return NFD_SUCCESS;
    });
}

nfd_result nfd_extraction_step(nfd_extraction* extraction, nfd_mesh** out_mesh,
                               nfd_extraction_level* out_info) {
    if (!out_mesh) return NFD_ERROR_INVALID_ARGUMENT;
    *out_mesh = nullptr;
    if (!extraction || extraction->done || extraction->failed) return NFD_ERROR_INVALID_ARGUMENT;
    if (out_info && out_info->struct_size && out_info->struct_size < kExtractionLevel02)
        return NFD_ERROR_INVALID_ARGUMENT;
    const nfd_result r = guarded([&] {
        auto mesh = std::make_unique<nfd_mesh>();
        nfd::LevelReport report;
        const nfd_result s = extraction->impl->step(&mesh->data, &mesh->stats, &report);
        if (s != NFD_SUCCESS) return s;
        extraction->done = report.done;
        if (out_info) {
            nfd_extraction_level info{};
            info.resolution = report.cells_per_axis;
            info.index = extraction->top - report.level;
            info.done = report.done ? 1 : 0;
            info.points_evaluated = report.points_evaluated;
            info.gradients_evaluated = report.gradients_evaluated;
            info.next_host_bytes = report.next_host_bytes;
            info.next_device_bytes = report.next_device_bytes;
            write_level_info(info, out_info);
        }
        if (!report.meshed) return NFD_SUCCESS;
        mesh->data.offset = extraction->offset;
        if (extraction->colour) {
            const nfd_context& ctx = *extraction->context;
            const nfd_result c = nfd::colour_mesh(*extraction->colour, device_of(ctx),
                                                  ctx.cpu_threads, &mesh->data);
            if (c != NFD_SUCCESS) return c;
        }
        *out_mesh = mesh.release();
        return NFD_SUCCESS;
    });
    extraction->failed = r != NFD_SUCCESS;
    return r;
}

void nfd_extraction_destroy(nfd_extraction* extraction) { delete extraction; }

nfd_result nfd_grid_extract(nfd_context* context, const nfd_asset* asset,
                            const nfd_grid_options* options, nfd_grid** out_grid) {
    if (!out_grid) return NFD_ERROR_INVALID_ARGUMENT;
    *out_grid = nullptr;
    if (!context || !asset) return NFD_ERROR_INVALID_ARGUMENT;
    nfd_grid_options opts;
    if (nfd::read_options(options, kGridOptions02, &opts) != NFD_SUCCESS)
        return NFD_ERROR_INVALID_ARGUMENT;
    const uint32_t resolution = options_resolution(opts.resolution);
    if (!resolution) return NFD_ERROR_LIMIT_EXCEEDED;
    const nfd::Geometry& g = asset->file.geometry;
    return guarded([&] {
        // The CPU reference builds the grid on every context for now: a grid built on the device
        // (gpu/) has the same SparseGrid layout and takes its place here.
        nfd::SparseGrid sparse;
        nfd::GridOptions grid_options;
        grid_options.max_host_bytes = opts.max_host_bytes;
        const bool coloured = asset->file.has_colour() && !opts.skip_colour;
        grid_options.bytes_per_voxel = 16 + (coloured ? 24 : 0);  // ijk + value; rgb + unit xyz
        const nfd_result r =
            nfd::build_grid_cpu(g, resolution, grid_options, &sparse, context->cpu_threads);
        if (r != NFD_SUCCESS) return r;
        const float step = sparse.step;
        std::unique_ptr<nfd_grid> grid = finest_voxels(std::move(sparse), asset->file);
        const std::optional<nfd::ColourField> colour =
            nfd::colour_field(asset->file, opts.skip_colour != 0);
        if (colour) {
            const nfd_result c = colour_voxels(*colour, step, *context, grid.get());
            if (c != NFD_SUCCESS) return c;
        }
        *out_grid = grid.release();
        return NFD_SUCCESS;
    });
}

void nfd_grid_destroy(nfd_grid* grid) { delete grid; }

nfd_result nfd_grid_get_voxels(const nfd_grid* grid, nfd_grid_voxels* out_voxels) {
    if (!grid || !out_voxels) return NFD_ERROR_INVALID_ARGUMENT;
    *out_voxels = grid->voxels;
    return NFD_SUCCESS;
}

nfd_result nfd_grid_get_offset(const nfd_grid* grid, double* out_offset) {
    if (!grid || !out_offset) return NFD_ERROR_INVALID_ARGUMENT;
    std::copy(grid->offset.begin(), grid->offset.end(), out_offset);
    return NFD_SUCCESS;
}

nfd_result nfd_grid_get_colours(const nfd_grid* grid, const float** out_colours) {
    if (!grid || !out_colours) return NFD_ERROR_INVALID_ARGUMENT;
    *out_colours = grid->colours.empty() ? nullptr : grid->colours.data();
    return NFD_SUCCESS;
}

nfd_result nfd_grid_write_vdb(const nfd_grid* grid, const char* path, const char* source_name) {
    if (!grid || !path) return NFD_ERROR_INVALID_ARGUMENT;
#if NFD_WITH_OPENVDB
    const nfd::VdbWriteEntry write = nfd::vdb_module_entry();
    if (!write) return NFD_ERROR_UNSUPPORTED_FEATURE;
    const nfd::VdbWriteCall call{NFD_VERSION, &grid->voxels, grid->offset,
                                 grid->colours.empty() ? nullptr : grid->colours.data(),
                                 {source_name, grid->format_major, grid->format_minor}, path};
    return write(&call);
#else
    (void)source_name;
    return NFD_ERROR_UNSUPPORTED_FEATURE;
#endif
}


nfd_result nfd_queue_create(nfd_context* context, const nfd_queue_options* options,
                            nfd_queue** out_queue) {
    if (!out_queue) return NFD_ERROR_INVALID_ARGUMENT;
    *out_queue = nullptr;
    if (!context) return NFD_ERROR_INVALID_ARGUMENT;
    nfd_queue_options opts;
    if (nfd::read_options(options, kQueueOptions02, &opts) != NFD_SUCCESS)
        return NFD_ERROR_INVALID_ARGUMENT;
    return guarded([&] {
        const nfd::MemoryBytes budget{opts.host_budget_bytes, opts.device_budget_bytes};
        try {
            *out_queue = new nfd_queue{
                {}, context, std::make_unique<nfd::Queue>(opts.worker_threads, budget)};
        } catch (const std::system_error&) {  // a thread could not be started
            return NFD_ERROR_OUT_OF_MEMORY;
        }
        return NFD_SUCCESS;
    });
}

void nfd_queue_destroy(nfd_queue* queue) { delete queue; }

}  // extern "C"

namespace {

nfd_result read_job_request(const nfd_mesh_options* mesh_options, const nfd_job_options* job_options,
                            nfd_job::Request* out) {
    if (nfd::read_options(mesh_options, kMeshOptions02, &out->mesh) != NFD_SUCCESS ||
        nfd::read_options(job_options, kJobOptions02, &out->job) != NFD_SUCCESS)
        return NFD_ERROR_INVALID_ARGUMENT;
    out->resolution = options_resolution(out->mesh.resolution);
    if (!out->resolution) return NFD_ERROR_LIMIT_EXCEEDED;
    out->top = nfd::refinement_levels(out->resolution);
    if (!valid_ladder_mask(out->job.mesh_levels, out->top)) return NFD_ERROR_INVALID_ARGUMENT;
    out->mask = out->job.mesh_levels ? grid_level_mask(out->job.mesh_levels, out->top) : 1u;
    return NFD_SUCCESS;
}

// The job's work on `file`; also sets the handle's offset, which its meshes carry.
std::unique_ptr<nfd::ExtractWork> job_work(nfd_context& ctx, const nfd::ParsedFile& file,
                                           const nfd_job::Request& request, nfd_job& handle) {
    handle.offset = offset_of(file.geometry);
    return std::make_unique<nfd::ExtractWork>(
        file.geometry, nfd::colour_field(file, request.mesh.skip_colour != 0), request.resolution,
        request.mask, device_of(ctx), ctx.cpu_threads,
        nfd::MemoryBytes{request.mesh.max_host_bytes, request.mesh.max_device_bytes},
        request.mesh.sample_band != 0);
}

std::unique_ptr<nfd_job> job_handle(const nfd_job::Request& request,
                                    std::function<void(nfd_job_status)>* callback) {
    auto handle = std::make_unique<nfd_job>();
    handle->levels_total = request.top + 1;
    handle->final_resolution = request.resolution;
    if (request.job.callback)
        *callback = [job = handle.get(), fn = request.job.callback, user = request.job.user_data](
                        nfd_job_status status) { fn(job, status, user); };
    return handle;
}

// Whether a stream job's stream holds the asset the job needs (nfd_queue_submit_stream).
bool input_ready(const nfd_stream& stream, const nfd_job::Request& request) {
    const nfd::FileParser& parser = stream.reader.parser();
    return request.mesh.skip_colour ? parser.geometry_read() : parser.complete();
}

// After the stream job's input changed (under its lock): starts the job once its asset is there,
// fails it if the stream failed first.
void advance_input(nfd_job& handle) {
    nfd_job::Input& in = *handle.input;
    if (in.started) return;
    const nfd_result error = in.stream->reader.error();
    if (error != NFD_SUCCESS || input_ready(*in.stream, in.request)) in.started = true;
    if (error != NFD_SUCCESS) return handle.job->fail_input(error);
    if (!in.started) return;
    const nfd_result r = guarded([&] {
        handle.job->start(job_work(*in.context, in.stream->reader.parser().file(), in.request, handle));
        return NFD_SUCCESS;
    });
    if (r != NFD_SUCCESS) handle.job->fail_input(r);
}

// Before a stream job's feed or finish: NFD_SUCCESS to go on, else what to return.
nfd_result input_open(nfd_job& handle) {
    nfd_job::Input& in = *handle.input;
    if (in.started || handle.job->awaiting_input()) return NFD_SUCCESS;
    const nfd_result error = in.stream->reader.error();
    return error != NFD_SUCCESS ? error : NFD_ERROR_CANCELLED;  // cancelled before it started
}

}  // namespace

extern "C" {

nfd_result nfd_queue_submit(nfd_queue* queue, const nfd_asset* asset,
                            const nfd_mesh_options* mesh_options,
                            const nfd_job_options* job_options, nfd_job** out_job) {
    if (!out_job) return NFD_ERROR_INVALID_ARGUMENT;
    *out_job = nullptr;
    if (!queue || !asset) return NFD_ERROR_INVALID_ARGUMENT;
    nfd_job::Request request;
    const nfd_result r = read_job_request(mesh_options, job_options, &request);
    if (r != NFD_SUCCESS) return r;
    return guarded([&] {
        std::function<void(nfd_job_status)> callback;
        std::unique_ptr<nfd_job> handle = job_handle(request, &callback);
        auto work = job_work(*queue->context, asset->file, request, *handle);
        if (!queue->queue->submit(std::move(work), request.job.priority, std::move(callback),
                                  &handle->job))
            return NFD_ERROR_CANCELLED;  // submitted from a callback while the queue is destroyed
        *out_job = handle.release();
        return NFD_SUCCESS;
    });
}

nfd_result nfd_queue_submit_stream(nfd_queue* queue, nfd_stream* stream,
                                   const nfd_mesh_options* mesh_options,
                                   const nfd_job_options* job_options, nfd_job** out_job) {
    if (!out_job) return NFD_ERROR_INVALID_ARGUMENT;
    *out_job = nullptr;
    if (!queue || !stream) return NFD_ERROR_INVALID_ARGUMENT;
    nfd_job::Request request;
    nfd_result r = read_job_request(mesh_options, job_options, &request);
    if (r != NFD_SUCCESS) return r;
    if ((r = stream->reader.error()) != NFD_SUCCESS) return r;
    if (stream->complete_asset_taken) return NFD_ERROR_INVALID_ARGUMENT;  // the file went with it
    // Everything that may fail comes before the job owns the stream: on failure the caller keeps it.
    return guarded([&] {
        std::function<void(nfd_job_status)> callback;
        std::unique_ptr<nfd_job> handle = job_handle(request, &callback);
        auto input = std::make_unique<nfd_job::Input>();
        input->context = queue->context;
        input->request = request;
        std::unique_ptr<nfd::ExtractWork> work;
        if (input_ready(*stream, request))
            work = job_work(*queue->context, stream->reader.parser().file(), request, *handle);
        input->started = work != nullptr;
        const bool submitted =
            work ? queue->queue->submit(std::move(work), request.job.priority, std::move(callback),
                                        &handle->job)
                 : queue->queue->submit_awaiting(request.job.priority, std::move(callback),
                                                 &handle->job);
        if (!submitted) return NFD_ERROR_CANCELLED;
        input->stream.reset(stream);
        if (!stream->prepare_context) stream->prepare_context = queue->context;
        handle->input = std::move(input);
        *out_job = handle.release();
        return NFD_SUCCESS;
    });
}

nfd_result nfd_job_feed(nfd_job* job, const void* bytes, size_t size,
                        nfd_stream_progress* out_progress) {
    if (!job || !job->input) return NFD_ERROR_INVALID_ARGUMENT;
    std::lock_guard<std::mutex> lock(job->input->mutex);
    const nfd_result open = input_open(*job);
    if (open != NFD_SUCCESS) {
        if (out_progress) *out_progress = progress_of(*job->input->stream);
        return open;
    }
    const nfd_result r = nfd_stream_feed(job->input->stream.get(), bytes, size, out_progress);
    advance_input(*job);
    return r;
}

nfd_result nfd_job_finish_input(nfd_job* job) {
    if (!job || !job->input) return NFD_ERROR_INVALID_ARGUMENT;
    std::lock_guard<std::mutex> lock(job->input->mutex);
    const nfd_result open = input_open(*job);
    if (open != NFD_SUCCESS) return open;
    const nfd_result r = nfd_stream_finish(job->input->stream.get());
    advance_input(*job);
    if (!job->input->started) {  // a file that ended before what the job needs
        job->input->started = true;
        job->job->fail_input(r);
    }
    return r;
}

nfd_result nfd_queue_get_stats(const nfd_queue* queue, nfd_queue_stats* out_stats) {
    if (!queue || !out_stats) return NFD_ERROR_INVALID_ARGUMENT;
    *out_stats = queue->queue->stats();
    return NFD_SUCCESS;
}

nfd_job_status nfd_job_poll(const nfd_job* job) {
    return job ? job->job->status() : NFD_JOB_FAILED;
}

nfd_job_status nfd_job_wait(nfd_job* job, uint64_t timeout_ns) {
    return job ? job->job->wait(timeout_ns) : NFD_JOB_FAILED;
}

nfd_result nfd_job_cancel(nfd_job* job) {
    if (!job) return NFD_ERROR_INVALID_ARGUMENT;
    job->job->cancel();
    return NFD_SUCCESS;
}

nfd_result nfd_job_take_mesh(nfd_job* job, nfd_mesh** out_mesh) {
    if (!out_mesh) return NFD_ERROR_INVALID_ARGUMENT;
    *out_mesh = nullptr;
    if (!job) return NFD_ERROR_INVALID_ARGUMENT;
    return guarded([&] {
        nfd_result result;
        std::optional<nfd::MeshResult> taken = job->job->take_mesh(&result);
        if (!taken) return result;  // DONE and taken before: NFD_SUCCESS with no mesh
        auto mesh = std::make_unique<nfd_mesh>();
        mesh->data = std::move(taken->data);
        mesh->data.offset = job->offset;
        mesh->stats = taken->stats;
        *out_mesh = mesh.release();
        return NFD_SUCCESS;
    });
}

nfd_result nfd_job_get_progress(const nfd_job* job, nfd_job_progress* out_progress) {
    if (!job || !out_progress) return NFD_ERROR_INVALID_ARGUMENT;
    if (out_progress->struct_size && out_progress->struct_size < kJobProgress1)
        return NFD_ERROR_INVALID_ARGUMENT;
    const nfd::Job::Progress p = job->job->progress();
    const uint32_t caller_size = out_progress->struct_size;
    nfd_job_progress info{};
    info.levels_done = p.levels_done;
    info.levels_total = job->levels_total;
    info.newest_mesh_resolution = p.newest_mesh_resolution;
    info.taken_mesh_resolution = p.taken_mesh_resolution;
    info.final_resolution = job->final_resolution;
    std::memcpy(out_progress, &info,
                std::min(caller_size ? size_t(caller_size) : kJobProgress1, sizeof info));
    out_progress->struct_size = caller_size;
    return NFD_SUCCESS;
}

void nfd_job_destroy(nfd_job* job) {
    if (!job) return;
    job->job->release();
    delete job;
}

nfd_result nfd_recording_create(nfd_context* context, const nfd_asset* asset,
                                const nfd_recording_options* options,
                                nfd_recording** out_recording) {
    if (!out_recording) return NFD_ERROR_INVALID_ARGUMENT;
    *out_recording = nullptr;
    if (!context || !asset) return NFD_ERROR_INVALID_ARGUMENT;
    nfd_recording_options opts;
    if (nfd::read_options(options, kRecordingOptions03, &opts) != NFD_SUCCESS)
        return NFD_ERROR_INVALID_ARGUMENT;
#if NFD_WITH_VULKAN
    if (!context->gpu) return NFD_ERROR_INVALID_ARGUMENT;
    const uint32_t resolution = options_resolution(opts.resolution);
    if (!resolution) return NFD_ERROR_LIMIT_EXCEEDED;
    nfd::gpu::Capacities c = nfd::gpu::default_capacities(resolution);
    if (opts.max_cells) c.cells = opts.max_cells;
    if (opts.max_gradient_points) c.gradient_points = opts.max_gradient_points;
    if (opts.max_vertices) c.vertices = opts.max_vertices;
    if (opts.max_triangles) c.triangles = opts.max_triangles;
    if (c.cells > NFD_MAX_RECORDING_CELLS || c.gradient_points > NFD_MAX_RECORDING_ITEMS ||
        c.vertices > NFD_MAX_RECORDING_ITEMS || c.triangles > NFD_MAX_RECORDING_ITEMS)
        return NFD_ERROR_LIMIT_EXCEEDED;
    if (asset->file.geometry.field != nfd::FieldType::Udf) c.gradient_points = 0;
    return guarded([&] {
        auto recording = std::make_unique<nfd_recording>();
        recording->offset = offset_of(asset->file.geometry);
        const nfd_result r = nfd::gpu::make_recording(*context->gpu, asset->file.geometry,
                                                      resolution, c, &recording->impl);
        if (r == NFD_SUCCESS) *out_recording = recording.release();
        return r;
    });
#else
    return NFD_ERROR_INVALID_ARGUMENT;  // no Vulkan context in this build
#endif
}

nfd_result nfd_recording_get_mesh(const nfd_recording* recording, nfd_device_mesh* out_mesh) {
    if (!recording || !out_mesh) return NFD_ERROR_INVALID_ARGUMENT;
#if NFD_WITH_VULKAN
    const nfd::gpu::DeviceMeshHandles h = nfd::gpu::device_mesh(*recording->impl);
    *out_mesh = {h.positions, h.normals, h.indices, h.draw, h.vertex_capacity,
                 h.triangle_capacity};
    return NFD_SUCCESS;
#else
    return NFD_ERROR_INVALID_ARGUMENT;
#endif
}

nfd_result nfd_recording_record(nfd_recording* recording, void* command_buffer) {
    if (!recording || !command_buffer) return NFD_ERROR_INVALID_ARGUMENT;
#if NFD_WITH_VULKAN
    return guarded([&] { return nfd::gpu::record(*recording->impl, command_buffer); });
#else
    return NFD_ERROR_INVALID_ARGUMENT;
#endif
}

nfd_result nfd_recording_finish(nfd_recording* recording, nfd_recording_result* out_result) {
    if (!recording || !out_result) return NFD_ERROR_INVALID_ARGUMENT;
    const uint32_t caller_size = out_result->struct_size;
    if (caller_size && caller_size < kRecordingResult03) return NFD_ERROR_INVALID_ARGUMENT;
#if NFD_WITH_VULKAN
    nfd::gpu::RecordingTotals t;
    const nfd_result r = nfd::gpu::finish(*recording->impl, &t);
    if (r != NFD_SUCCESS && r != NFD_ERROR_CAPACITY_EXCEEDED) return r;
    nfd_recording_result out{};
    out.vertex_count = t.vertices;
    out.triangle_count = t.triangles;
    out.needed_cells = t.needed.cells;
    out.needed_gradient_points = t.needed.gradient_points;
    out.needed_vertices = t.needed.vertices;
    out.needed_triangles = t.needed.triangles;
    out.stats = public_stats(t.stats);
    std::memcpy(out_result, &out,
                std::min(caller_size ? size_t(caller_size) : kRecordingResult03, sizeof out));
    out_result->struct_size = caller_size;
    return r;
#else
    return NFD_ERROR_INVALID_ARGUMENT;
#endif
}

nfd_result nfd_recording_read_mesh(const nfd_recording* recording, nfd_mesh** out_mesh) {
    if (!out_mesh) return NFD_ERROR_INVALID_ARGUMENT;
    *out_mesh = nullptr;
    if (!recording) return NFD_ERROR_INVALID_ARGUMENT;
#if NFD_WITH_VULKAN
    return guarded([&] {
        auto mesh = std::make_unique<nfd_mesh>();
        const nfd_result r = nfd::gpu::read_mesh(*recording->impl, &mesh->data, &mesh->stats);
        if (r != NFD_SUCCESS) return r;
        mesh->data.offset = recording->offset;
        *out_mesh = mesh.release();
        return NFD_SUCCESS;
    });
#else
    return NFD_ERROR_INVALID_ARGUMENT;
#endif
}

void nfd_recording_destroy(nfd_recording* recording) { delete recording; }

}  // extern "C"
