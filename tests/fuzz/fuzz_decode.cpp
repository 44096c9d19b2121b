// libFuzzer target: everything a decode does behind the parser, on the C++ path, for any file the
// parser accepts: a mesh at a small resolution (8-143, from the input's last byte) with its colours,
// points sampled on it and coloured, the sparse grid with its colours, and the PLY, glTF and VDB
// writers. Every output must be finite (colours in [0, 1]); anything else aborts.
#include <nfdecode/nfdecode.h>
#include <unistd.h>

#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include "fuzz_util.h"

namespace {

void require_finite_f64(const double* v, size_t n) {
    for (size_t i = 0; i < n; ++i) require(std::isfinite(v[i]));
}

std::string scratch_path(const char* extension) {
    return "/tmp/nfd_fuzz_decode_" + std::to_string(::getpid()) + extension;
}

void decode(const nfd_asset* asset, uint32_t resolution, bool sample_band) {
    nfd_context* ctx = cpu_context();
    nfd_mesh_options mo{};
    mo.struct_size = sizeof mo;
    mo.resolution = resolution;
    mo.sample_band = sample_band;
    nfd_mesh* mesh = nullptr;
    const nfd_result r = nfd_mesh_extract(ctx, asset, &mo, &mesh);
    if (r == NFD_ERROR_OUT_OF_MEMORY) return;
    require(r == NFD_SUCCESS);
    nfd_mesh_data d{};
    const float* colours = nullptr;
    read_valid_mesh(mesh, &d, &colours);
    if (d.triangle_count > 0) {
        std::vector<float> points(3 * 64), normals(3 * 64), rgb(3 * 64);
        require(nfd_mesh_sample_points(mesh, 64, 1, points.data(), normals.data()) == NFD_SUCCESS);
        require_finite(points.data(), points.size());
        const nfd_result c = nfd_asset_evaluate_colour(ctx, asset, points.data(), 64, rgb.data());
        require(c == (colours ? NFD_SUCCESS : NFD_ERROR_NO_COLOUR));
        if (colours) require_finite(rgb.data(), rgb.size(), true);
        double offset[3];  // a 64-bit frame's center: finite, so the double PLY is too
        require(nfd_mesh_get_offset(mesh, offset) == NFD_SUCCESS);
        require_finite_f64(offset, 3);
        require(nfd_points_write_placed_ply(points.data(), normals.data(),
                                            colours ? rgb.data() : nullptr, 64, offset,
                                            scratch_path(".points.ply").c_str()) == NFD_SUCCESS);
    }
    require(nfd_mesh_write_ply(mesh, scratch_path(".ply").c_str()) == NFD_SUCCESS);
    require(nfd_mesh_write_glb(mesh, scratch_path(".glb").c_str()) == NFD_SUCCESS);
    nfd_mesh_destroy(mesh);

    nfd_grid_options go{};
    go.struct_size = sizeof go;
    go.resolution = resolution;
    nfd_grid* grid = nullptr;
    const nfd_result g = nfd_grid_extract(ctx, asset, &go, &grid);
    if (g == NFD_ERROR_OUT_OF_MEMORY) return;
    require(g == NFD_SUCCESS);
    nfd_grid_voxels v{};
    require(nfd_grid_get_voxels(grid, &v) == NFD_SUCCESS);
    require(nfd_grid_get_colours(grid, &colours) == NFD_SUCCESS);
    if (colours) require_finite(colours, 3 * v.count, true);
    const nfd_result w = nfd_grid_write_vdb(grid, scratch_path(".vdb").c_str(), "fuzz.nfc");
    // UNSUPPORTED_FEATURE: a build without OpenVDB; LIMIT_EXCEEDED: a transform it cannot hold.
    require(w == NFD_SUCCESS || w == NFD_ERROR_UNSUPPORTED_FEATURE || w == NFD_ERROR_LIMIT_EXCEEDED);
    nfd_grid_destroy(grid);
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    if (size == 0 || !cpu_context()) return 0;
    // The last byte picks the decode and is not part of the file: below 0x80 a resolution of
    // 8..32 (the coarsest level only); else 64..79 (one refined level, odd cell counts included),
    // or with bit 0x20 128..143 (two: surface following's near-zero cells act on the first),
    // sampling an SDF's band when bit 0x40 is set, else following its surface.
    const uint8_t pick = data[size - 1];
    const bool refined = pick & 0x80;
    const uint32_t resolution = refined ? (pick & 0x20 ? 128 : 64) + (pick & 15)
                                        : NFD_MIN_RESOLUTION + pick % 25;
    nfd_asset* asset = nullptr;
    if (nfd_asset_create(data, size - 1, &asset) != NFD_SUCCESS) return 0;
    decode(asset, resolution, refined && (pick & 0x40));
    nfd_asset_destroy(asset);
    return 0;
}
