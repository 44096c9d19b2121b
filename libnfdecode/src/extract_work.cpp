// One-step extraction work for the queue (extract_work.h) and the bound of its memory.
#include "extract_work.h"

#include <utility>

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
// operator new; every Vulkan buffer's bytes) over the 5 golden vectors and the 19 bench assets
// (bench/out/nfc) at resolutions 64, 128, 256 and some at 512. Peak = a fixed part (the CPU grid's
// evaluation chunk of 2^20 points: 20 bytes each for SDF, 32 for UDF; the coarse level) plus a
// part that grows with the band, resolution^2 times the surface's area.
//   CPU host peak: at most 19.5 MB + 1350 B * r^2 (dragon-udf w32: 88 MB at 256, 383 MB at 512;
//   a typical SDF 480 B * r^2).
//   Vulkan: DEVICE and HOST below, from the same assets.
// The bounds take the fixed part as 32 MiB and the band part at 2.25x the largest measured.
MemoryBytes extract_bytes_bound(const Geometry& geometry, uint32_t resolution, bool vulkan) {
    const uint64_t r2 = uint64_t(resolution) * resolution;
    MemoryBytes b;
    if (vulkan) {
        b.host = (uint64_t(8) << 20) + 1024 * r2;
        b.device = (uint64_t(32) << 20) + 3072 * r2;
    } else {
        b.host = (uint64_t(32) << 20) + 3072 * r2;
    }
    b.host += geometry_bytes(geometry);
    return b;
}

ExtractWork::ExtractWork(const Geometry& geometry, uint32_t resolution, gpu::Device* device,
                         unsigned cpu_threads)
    : geometry_(geometry), resolution_(resolution), device_(device), cpu_threads_(cpu_threads),
      bound_(extract_bytes_bound(geometry, resolution, device != nullptr)) {}

nfd_result ExtractWork::step(StepResult* out) {
    MeshResult mesh;
    nfd_result r;
#if NFD_WITH_VULKAN
    if (device_)
        r = gpu::extract_mesh(*device_, geometry_, resolution_, &mesh.data, &mesh.stats);
    else
#endif
        r = extract_mesh_cpu(geometry_, resolution_, &mesh.data, &mesh.stats, cpu_threads_);
    if (r != NFD_SUCCESS) return r;
    out->mesh = std::move(mesh);
    out->finished = true;
    return NFD_SUCCESS;
}

}  // namespace nfd
