// The progressive extraction as queue work (extract_work.h) and the bound of its first step.
#include "extract_work.h"

#include <algorithm>
#include <utility>

#include "grid.h"

#if NFD_WITH_VULKAN
#include "gpu/gpu_decode.h"
#endif

namespace nfd {
namespace {

uint64_t geometry_bytes(const Geometry& g) {
    uint64_t floats = g.network.frequencies.size();
    for (const Layer& layer : g.network.layers) floats += layer.weights.size() + layer.bias.size();
    return 4 * floats + sizeof(Geometry);
}

}  // namespace

// The bounds, measured with tests/cpp/test_memory_bound.cpp's counters (every heap byte through
// operator new; every Vulkan buffer's memory) over the 5 golden vectors and the 19 bench assets
// (bench/out/nfc) at resolutions 64, 128 and 256, and three of them at 512. A peak is a fixed part
// plus a part that follows the band of the sparse grid: resolution^2 times the surface's area.
// The largest, all from dragon-udf w32 (the most detailed surface) unless said:
//   CPU host:     19.5 MB fixed (the grid's evaluation chunk: 2^20 points of 20 bytes, SDF, or 32,
//                 UDF) + 1350 B * r^2: 88 MB at 256, 383 MB at 512 (a typical SDF: 480 B * r^2).
//   Vulkan device: 40 MB at 256 (615 B * r^2); golden vectors 14-20 MB.
//   Vulkan host:  24 MB at 256 (365 B * r^2: the mesh read back), and 55 MB once per network
//                 shape, when the job compiles its field pipeline (lavapipe, whose compiler is
//                 LLVM, at shirt w24's first job; other drivers differ).
// Bounds: the fixed part rounded up, the band part at 2.2 to 2.8 times the largest measured.
// A job uses it at 32 to 63 cells only, where the fixed part dominates: test_memory_bound.cpp
// checks a job's first step (and every later one) against what the job reserves.
MemoryBytes extract_bytes_bound(const Geometry& geometry, uint32_t resolution, bool vulkan) {
    const uint64_t r2 = uint64_t(resolution) * resolution;
    constexpr uint64_t MiB = uint64_t(1) << 20;
    MemoryBytes b;
    if (vulkan) {
        b.host = 64 * MiB + 1024 * r2;
        b.device = 16 * MiB + 1536 * r2;
    } else {
        b.host = 32 * MiB + 3072 * r2;
    }
    b.host += geometry_bytes(geometry);
    return b;
}

ExtractWork::ExtractWork(const Geometry& geometry, std::optional<ColourField> colour,
                         uint32_t resolution, uint32_t mesh_mask, gpu::Device* device,
                         unsigned cpu_threads, MemoryBytes limit, bool band)
    : geometry_(geometry), colour_(std::move(colour)), resolution_(resolution), top_(refinement_levels(resolution)),
      mesh_mask_(mesh_mask), device_(device), cpu_threads_(cpu_threads), limit_(limit), band_(band) {
    restart();
}

void ExtractWork::restart() {
    extraction_.reset();
    held_ = MemoryBytes{};
    next_ = extract_bytes_bound(geometry_, cells_at_level(resolution_, top_), device_ != nullptr);
}

nfd_result ExtractWork::step(StepResult* out) {
    const MemoryBytes need = next_step_bytes();
    if ((limit_.host && need.host > limit_.host) || (limit_.device && device_ && need.device > limit_.device))
        return NFD_ERROR_LIMIT_EXCEEDED;
    if (!extraction_) {
#if NFD_WITH_VULKAN
        if (device_) {
            const nfd_result r =
                gpu::make_extraction(*device_, geometry_, resolution_, mesh_mask_, band_,
                                     &extraction_);
            if (r != NFD_SUCCESS) return r;
        } else
#endif
            extraction_ = make_extraction_cpu(geometry_, resolution_, mesh_mask_, cpu_threads_, band_);
    }
    MeshResult mesh;
    LevelReport report;
    const nfd_result r = extraction_->step(&mesh.data, &mesh.stats, &report);
    if (r != NFD_SUCCESS) return r;
    held_ = held_ + next_;
    next_ = MemoryBytes{report.next_host_bytes, report.next_device_bytes};
    levels_done_ = std::max(levels_done_, top_ - report.level + 1);
    out->levels_done = levels_done_;
    if (report.meshed) {
        if (colour_) {
            const nfd_result c = colour_mesh(*colour_, device_, cpu_threads_, &mesh.data);
            if (c != NFD_SUCCESS) return c;
        }
        out->mesh = std::move(mesh);
        out->mesh_resolution = report.cells_per_axis;
        mesh_mask_ &= ((1u << report.level) - 1) | 1u;  // finer levels only, the finest always
    }
    out->finished = report.done;
    return NFD_SUCCESS;
}

}  // namespace nfd
