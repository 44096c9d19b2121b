// Shared by the sparse-grid tests (test_grid_api.cpp, test_vdb.cpp): a golden vector decoded on
// the CPU with its grid, and the check of grid distances against nfd_asset_evaluate.
#pragma once
#include <gtest/gtest.h>
#include <nfdecode/nfdecode.h>

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "test_util.h"

namespace nfd::test {

// The grid's positions are ijk * voxel_size + origin, the grid's own unit coordinates -1 + i * step
// (both f32) mapped to the original frame: they differ by float rounding, ~2e-7 in the unit frame,
// which moves a field of gradient norm <= 2 by ~5e-7. 1e-5 (units of scale) is the golden vectors'
// field tolerance (tests/vectors/README.md); measured at 256: 3e-7 (bunny), 4.5e-7 (T-shirt).
constexpr double kGridValueTolerance = 1e-5;

// A golden vector on a CPU context and its grid at `resolution`; everything released at scope exit.
struct GoldenGrid {
    nfd_context* context = nullptr;
    nfd_asset* asset = nullptr;
    nfd_asset_info info{};
    nfd_grid* grid = nullptr;
    nfd_grid_voxels voxels{};

    GoldenGrid(const std::string& name, uint32_t resolution) {
        nfd_context_options co = {};
        co.device = NFD_DEVICE_CPU;
        EXPECT_EQ(nfd_context_create(&co, &context), NFD_SUCCESS);
        const Bytes bytes = read_bytes(golden_path(name, ".nfc"));
        EXPECT_EQ(nfd_asset_create(bytes.data(), bytes.size(), &asset), NFD_SUCCESS);
        EXPECT_EQ(nfd_asset_get_info(asset, &info), NFD_SUCCESS);
        nfd_grid_options go = {};
        go.resolution = resolution;
        EXPECT_EQ(nfd_grid_extract(context, asset, &go, &grid), NFD_SUCCESS);
        EXPECT_EQ(nfd_grid_get_voxels(grid, &voxels), NFD_SUCCESS);
    }
    ~GoldenGrid() {
        nfd_grid_destroy(grid);
        nfd_asset_destroy(asset);
        nfd_context_destroy(context);
    }
    GoldenGrid(const GoldenGrid&) = delete;
    GoldenGrid& operator=(const GoldenGrid&) = delete;

    // The field at `points` (original frame, xyz interleaved), in original units.
    std::vector<float> evaluate(const std::vector<float>& points) const {
        std::vector<float> values(points.size() / 3);
        EXPECT_EQ(nfd_asset_evaluate(context, asset, points.data(), values.size(), values.data()),
                  NFD_SUCCESS);
        for (float& v : values) v *= info.scale;
        return values;
    }

    // The largest |values[n] - field(points[n])| in units of scale.
    double max_deviation(const std::vector<float>& points, const std::vector<float>& values) const {
        const std::vector<float> expected = evaluate(points);
        double worst = 0;
        for (size_t n = 0; n < values.size(); ++n)
            worst = std::max(worst, std::fabs(double(values[n]) - expected[n]) / info.scale);
        return worst;
    }
};

}  // namespace nfd::test
