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
