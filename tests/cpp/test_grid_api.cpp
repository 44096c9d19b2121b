// The sparse-grid C API (nfd_grid_*): argument checks, limits and ownership, and the voxels it
// hands out checked against the documented layout and nfd_asset_evaluate on the golden vectors.
// The OpenVDB file itself is test_vdb.cpp's.
#include <gtest/gtest.h>
#include <nfdecode/nfdecode.h>
#include <unistd.h>

#include <cstdio>
#include <filesystem>

#include "grid.h"
#include "grid_util.h"
#include "test_util.h"

namespace nfd::test {
namespace {

struct GridApi : ::testing::Test {
    nfd_context* ctx = nullptr;
    nfd_asset* asset = nullptr;
    void SetUp() override {
        nfd_context_options o = {};
        o.device = NFD_DEVICE_CPU;
        ASSERT_EQ(nfd_context_create(&o, &ctx), NFD_SUCCESS);
        const float center[3] = {1.0f, -2.0f, 0.5f};
        const Bytes b = geom_file(closed_blob(2.0f, center));
        ASSERT_EQ(nfd_asset_create(b.data(), b.size(), &asset), NFD_SUCCESS);
    }
    void TearDown() override {
        nfd_asset_destroy(asset);
        nfd_context_destroy(ctx);
    }
    size_t voxel_count(uint32_t resolution) const {
        nfd_grid_options go = {};
        go.resolution = resolution;
        nfd_grid* grid = nullptr;
        EXPECT_EQ(nfd_grid_extract(ctx, asset, &go, &grid), NFD_SUCCESS);
        nfd_grid_voxels v = {};
        EXPECT_EQ(nfd_grid_get_voxels(grid, &v), NFD_SUCCESS);
        nfd_grid_destroy(grid);
        return v.count;
    }
};

TEST_F(GridApi, ArgumentsLimitsAndDefaults) {
    EXPECT_EQ(nfd_grid_extract(ctx, asset, nullptr, nullptr), NFD_ERROR_INVALID_ARGUMENT);
    nfd_grid* grid = reinterpret_cast<nfd_grid*>(0x1);
    EXPECT_EQ(nfd_grid_extract(nullptr, asset, nullptr, &grid), NFD_ERROR_INVALID_ARGUMENT);
    EXPECT_EQ(grid, nullptr);
    EXPECT_EQ(nfd_grid_extract(ctx, nullptr, nullptr, &grid), NFD_ERROR_INVALID_ARGUMENT);
    nfd_grid_options go = {};
    for (uint32_t r : {NFD_MIN_RESOLUTION - 1, NFD_MAX_RESOLUTION + 1, 0xFFFFFFFFu}) {
        go.resolution = r;
        grid = reinterpret_cast<nfd_grid*>(0x1);
        EXPECT_EQ(nfd_grid_extract(ctx, asset, &go, &grid), NFD_ERROR_LIMIT_EXCEEDED) << r;
        EXPECT_EQ(grid, nullptr);
    }
    nfd_grid_destroy(nullptr);

    // NULL and zeroed options mean NFD_DEFAULT_RESOLUTION.
    const nfd_grid_options zero = {};
    for (const nfd_grid_options* options : {static_cast<const nfd_grid_options*>(nullptr), &zero}) {
        ASSERT_EQ(nfd_grid_extract(ctx, asset, options, &grid), NFD_SUCCESS);
        nfd_grid_voxels v;
        ASSERT_EQ(nfd_grid_get_voxels(grid, &v), NFD_SUCCESS);
        EXPECT_EQ(v.resolution, NFD_DEFAULT_RESOLUTION);
        nfd_grid_destroy(grid);
    }

    go.resolution = NFD_MIN_RESOLUTION;
    ASSERT_EQ(nfd_grid_extract(ctx, asset, &go, &grid), NFD_SUCCESS);
    nfd_grid_voxels v;
    EXPECT_EQ(nfd_grid_get_voxels(nullptr, &v), NFD_ERROR_INVALID_ARGUMENT);
    EXPECT_EQ(nfd_grid_get_voxels(grid, nullptr), NFD_ERROR_INVALID_ARGUMENT);
    double offset[3] = {1, 1, 1};
    EXPECT_EQ(nfd_grid_get_offset(nullptr, offset), NFD_ERROR_INVALID_ARGUMENT);
    EXPECT_EQ(nfd_grid_get_offset(grid, nullptr), NFD_ERROR_INVALID_ARGUMENT);
    ASSERT_EQ(nfd_grid_get_offset(grid, offset), NFD_SUCCESS);
    EXPECT_EQ(offset[0], 0.0);  // no 64-bit frame: positions are original coordinates
    const std::string path = (std::filesystem::temp_directory_path() /
                              ("nfd_grid_api_" + std::to_string(::getpid()) + ".vdb"))
                                 .string();
    EXPECT_EQ(nfd_grid_write_vdb(nullptr, path.c_str(), "x.nfc"), NFD_ERROR_INVALID_ARGUMENT);
    EXPECT_EQ(nfd_grid_write_vdb(grid, nullptr, "x.nfc"), NFD_ERROR_INVALID_ARGUMENT);
#if !NFD_WITH_OPENVDB
    EXPECT_EQ(nfd_grid_write_vdb(grid, path.c_str(), "x.nfc"), NFD_ERROR_UNSUPPORTED_FEATURE);
    EXPECT_FALSE(std::filesystem::exists(path));  // refused before the file is touched
#endif
    nfd_grid_destroy(grid);
}

// The grid owns what it hands out: the context and the asset may go first.
TEST_F(GridApi, OutlivesContextAndAsset) {
    nfd_grid_options go = {};
    go.resolution = 16;
    nfd_grid* grid = nullptr;
    ASSERT_EQ(nfd_grid_extract(ctx, asset, &go, &grid), NFD_SUCCESS);
    nfd_asset_destroy(asset);
    nfd_context_destroy(ctx);
    asset = nullptr;
    ctx = nullptr;
    nfd_grid_voxels v;
    ASSERT_EQ(nfd_grid_get_voxels(grid, &v), NFD_SUCCESS);
    ASSERT_EQ(v.count, 17u * 17u * 17u);
    EXPECT_EQ(v.field_type, NFD_FIELD_SDF);
    double sum = 0;
    for (size_t n = 0; n < v.count; ++n) sum += v.values[n] + v.ijk[3 * n];
    EXPECT_TRUE(std::isfinite(sum));
    nfd_grid_destroy(grid);
}

// The header's claim: resolutions under 63 are not refined, so the band is the whole grid.
TEST_F(GridApi, UnrefinedResolutionsKeepTheWholeGrid) {
    for (uint32_t r : {NFD_MIN_RESOLUTION, 31u, 62u})
        EXPECT_EQ(voxel_count(r), size_t(r + 1) * (r + 1) * (r + 1)) << r;
    EXPECT_LT(voxel_count(63), size_t(64) * 64 * 64);
}

// Every voxel against the documented layout, the internal grid it exposes and the field itself.
void check_voxels(const std::string& name, uint32_t resolution, double max_fraction) {
    SCOPED_TRACE(name);
    const GoldenGrid g(name, resolution);
    const nfd_grid_voxels& v = g.voxels;
    const nfd_asset_info& info = g.info;
    EXPECT_EQ(v.resolution, resolution);
    EXPECT_EQ(v.field_type, info.field_type);
    EXPECT_FLOAT_EQ(v.voxel_size, 2.0f * info.scale / float(resolution));
    for (int a = 0; a < 3; ++a) EXPECT_FLOAT_EQ(v.origin[a], info.center[a] - info.scale);
    EXPECT_FLOAT_EQ(v.background, info.truncation * info.scale);

    // The finest level of the CPU reference grid, vertex for vertex.
    ParsedFile file;
    const Bytes bytes = read_bytes(golden_path(name, ".nfc"));
    ASSERT_EQ(parse_file(bytes.data(), bytes.size(), &file), NFD_SUCCESS);
    SparseGrid reference;
    ASSERT_EQ(build_grid_cpu(file.geometry, resolution, GridOptions{}, &reference), NFD_SUCCESS);
    ASSERT_EQ(v.count, reference.finest().vertices.size());

    std::vector<float> points(3 * v.count), values(v.values, v.values + v.count);
    int64_t previous_key = -1;
    size_t negative = 0;
    for (size_t n = 0; n < v.count; ++n) {
        const int32_t* ijk = v.ijk + 3 * n;
        int64_t key = 0;  // the documented order: block raster order, then raster order inside
        for (int a = 2; a >= 0; --a) {
            ASSERT_GE(ijk[a], 0);
            ASSERT_LE(ijk[a], int32_t(resolution));
            key = key * 256 + ijk[a] / 8;
        }
        for (int a = 2; a >= 0; --a) key = key * 8 + ijk[a] % 8;
        ASSERT_GT(key, previous_key) << "voxel " << n;
        previous_key = key;
        for (int a = 0; a < 3; ++a) points[3 * n + a] = float(ijk[a]) * v.voxel_size + v.origin[a];
        negative += v.values[n] < 0;
    }
    const double deviation = g.max_deviation(points, values);
    EXPECT_LE(deviation, kGridValueTolerance);
    const double fraction = double(v.count) / std::pow(resolution + 1.0, 3.0);
    EXPECT_LT(fraction, max_fraction);
    if (info.field_type == NFD_FIELD_SDF)
        EXPECT_GT(negative, v.count / 10);  // the band straddles the surface
    else
        EXPECT_EQ(negative, 0u);
    std::printf("  %s at %u: %zu voxels, %.2f%% of the dense grid; max |value - evaluate| = %.2g\n",
                name.c_str(), resolution, v.count, 100 * fraction, deviation);
}

// Measured at 256: bunny w16 6.1%, T-shirt 4.9% of the (resolution + 1)^3 vertices.
TEST(GridVoxels, BunnySdfAreTheFieldOnTheBand) { check_voxels("bunny_sdf_w16", 256, 0.07); }
TEST(GridVoxels, TshirtUdfAreTheFieldOnTheBand) { check_voxels("tshirt_udf_w16", 256, 0.06); }

}  // namespace
}  // namespace nfd::test
