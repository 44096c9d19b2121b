// The colour stage (FORMAT.md, "colr"): the colour network evaluated where the decoder emits
// geometry, at output vertices, sampled points or grid voxels, on the CPU or the Vulkan device.
#pragma once
#include <cstddef>
#include <optional>
#include <vector>

#include "bitstream.h"
#include "mesh.h"
#include "nfdecode/nfdecode.h"

#include "host_memory.h"

namespace nfd {
namespace gpu {
class Device;
}

// A colour network with the frame it is evaluated in (GEOM's, as positions are emitted): what a
// job or an extraction keeps of an asset, which may be destroyed while they run.
struct ColourField {
    Network network;
    float center[3] = {0, 0, 0};  // Geometry::emit_center
    float scale = 1.0f;
};

// The file's colour field, or none when it has no `colr` chunk or `skip` is set (geometry only).
std::optional<ColourField> colour_field(const ParsedFile& file, bool skip = false);

// Maps `count` original-frame points (xyz) to the unit frame in blocks of bounded size and calls
// fn(unit_xyz, n, first point index) on each; the first failure ends the walk. Shared by every
// evaluation of the API, so each maps positions the same way.
template <class Fn>
nfd_result for_each_unit_block(const float center[3], float scale, const float* points,
                               size_t count, Fn&& fn) {
    constexpr size_t kBlock = size_t(1) << 20;
    nfd::vector<float> unit(3 * (count < kBlock ? count : kBlock));
    for (size_t begin = 0; begin < count; begin += kBlock) {
        const size_t n = count - begin < kBlock ? count - begin : kBlock;
        for (size_t i = 0; i < 3 * n; ++i)
            unit[i] = (points[3 * begin + i] - center[i % 3]) / scale;
        const nfd_result r = fn(unit.data(), n, begin);
        if (r != NFD_SUCCESS) return r;
    }
    return NFD_SUCCESS;
}

// RGB in [0, 1] (3 floats per point) of n unit-frame points, on `device` when it is not null,
// else on the CPU with `threads`. May throw std::bad_alloc.
nfd_result evaluate_colour_unit(const Network& colour, const float* unit_xyz, size_t n,
                                gpu::Device* device, unsigned threads, float* out_rgb);

// The same for `count` original-frame points (xyz).
nfd_result evaluate_colour(const ColourField& colour, const float* points, size_t count,
                           gpu::Device* device, unsigned threads, float* out_rgb);

// Sets mesh->colours: the colour of every vertex (replacing any it had).
nfd_result colour_mesh(const ColourField& colour, gpu::Device* device, unsigned threads,
                       MeshData* mesh);

}  // namespace nfd
