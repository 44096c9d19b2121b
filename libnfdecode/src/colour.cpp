// The colour stage (colour.h): one network evaluation over the emitted positions.
#include "colour.h"

#include <algorithm>

#if NFD_WITH_VULKAN
#include "gpu/gpu_decode.h"
#endif

namespace nfd {

std::optional<ColourField> colour_field(const ParsedFile& file, bool skip) {
    if (skip || !file.colour) return std::nullopt;
    ColourField c;
    c.network = *file.colour;
    for (int a = 0; a < 3; ++a) c.center[a] = file.geometry.emit_center(a);
    c.scale = file.geometry.scale;
    return c;
}

nfd_result evaluate_colour_unit(const Network& colour, const float* unit_xyz, size_t n,
                                gpu::Device* device, unsigned threads, float* out_rgb) {
#if NFD_WITH_VULKAN
    if (device) {
        const nfd_result r = gpu::evaluate(*device, colour, unit_xyz, n, out_rgb);
        if (r != NFD_SUCCESS) return r;
    } else
#else
    (void)device;
#endif
        evaluate_cpu(colour, unit_xyz, n, out_rgb, threads);
    // A valid file can still hold weights whose products overflow (steps near the f32 maximum):
    // sin(inf) is NaN, and NaN is no colour. Such outputs read as 0, so colours stay in [0, 1].
    for (size_t i = 0; i < 3 * n; ++i)
        if (!(out_rgb[i] >= 0.0f && out_rgb[i] <= 1.0f)) out_rgb[i] = 0.0f;
    return NFD_SUCCESS;
}

nfd_result evaluate_colour(const ColourField& colour, const float* points, size_t count,
                           gpu::Device* device, unsigned threads, float* out_rgb) {
    return for_each_unit_block(colour.center, colour.scale, points, count,
                               [&](const float* unit, size_t n, size_t begin) {
                                   return evaluate_colour_unit(colour.network, unit, n, device,
                                                               threads, out_rgb + 3 * begin);
                               });
}

nfd_result colour_mesh(const ColourField& colour, gpu::Device* device, unsigned threads,
                       MeshData* mesh) {
    nfd::vector<float> rgb(mesh->positions.size());
    const nfd_result r = evaluate_colour(colour, mesh->positions.data(), mesh->vertex_count(),
                                         device, threads, rgb.data());
    if (r == NFD_SUCCESS) mesh->colours = std::move(rgb);
    return r;
}

}  // namespace nfd
