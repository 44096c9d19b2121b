// The documented limits reached, each with its error code (issue 13, item 3): resolution, the
// memory limits of one decode (nfd_mesh_options / nfd_grid_options max_*_bytes) on the CPU and
// Vulkan paths and for queue jobs. That a decode within its limit never holds more than it is
// the business of test_memory_bound.cpp (MemoryBound.LimitsAreNeverExceeded).
#include <gtest/gtest.h>
#include <nfdecode/nfdecode.h>

#include <algorithm>

#include "colour_util.h"
#include "test_util.h"

namespace nfd::test {
namespace {

constexpr uint64_t kTiny = 1u << 20;            // below any decode's first level
constexpr uint64_t kAmple = uint64_t(1) << 40;  // above any decode

nfd_result mesh_with_limits(nfd_context* ctx, const nfd_asset* asset, uint32_t resolution,
                            uint64_t host, uint64_t device, MeshPtr* out) {
    nfd_mesh_options mo{};
    mo.struct_size = sizeof mo;
    mo.resolution = resolution;
    mo.max_host_bytes = host;
    mo.max_device_bytes = device;
    nfd_mesh* m = reinterpret_cast<nfd_mesh*>(0x1);
    const nfd_result r = nfd_mesh_extract(ctx, asset, &mo, &m);
    EXPECT_EQ(r == NFD_SUCCESS, m != nullptr);
    out->reset(m);
    return r;
}

TEST(Limits, ResolutionOutsideTheCapsIsLimitExceeded) {
    const AssetPtr asset = make_asset(geom_file(closed_blob()));
    const ContextPtr ctx = cpu_context();
    for (uint32_t r : {NFD_MIN_RESOLUTION - 1, NFD_MAX_RESOLUTION + 1}) {
        MeshPtr mesh;
        EXPECT_EQ(mesh_with_limits(ctx.get(), asset.get(), r, 0, 0, &mesh), NFD_ERROR_LIMIT_EXCEEDED);
        nfd_grid_options go{};
        go.struct_size = sizeof go;
        go.resolution = r;
        nfd_grid* grid = nullptr;
        EXPECT_EQ(nfd_grid_extract(ctx.get(), asset.get(), &go, &grid), NFD_ERROR_LIMIT_EXCEEDED);
        EXPECT_EQ(grid, nullptr);
    }
}

// A decode under a limit it cannot keep stops with LIMIT_EXCEEDED; under an ample one it gives
// the unlimited decode's mesh, byte for byte, colours included; on every device.
TEST(Limits, MeshDecodeStopsAtItsMemoryLimit) {
    for (const std::string& name : golden_names()) {
        SCOPED_TRACE(name);
        const AssetPtr asset = make_asset(read_bytes(golden_path(name, ".nfc")));
        for (const ContextPtr& ctx : cpu_and_vulkan_contexts()) {
            SCOPED_TRACE(nfd_context_device_name(ctx.get()));
            const bool vulkan = nfd_context_device_kind(ctx.get()) == NFD_DEVICE_VULKAN;
            MeshPtr unlimited, limited, refused;
            ASSERT_EQ(mesh_with_limits(ctx.get(), asset.get(), 96, 0, 0, &unlimited), NFD_SUCCESS);
            ASSERT_EQ(mesh_with_limits(ctx.get(), asset.get(), 96, kAmple, kAmple, &limited),
                      NFD_SUCCESS);
            const MeshArrays a = arrays_of(unlimited.get()), b = arrays_of(limited.get());
            EXPECT_TRUE(a.same_geometry(b));
            EXPECT_EQ(a.colours, b.colours);
            EXPECT_EQ(mesh_with_limits(ctx.get(), asset.get(), 96, kTiny, 0, &refused),
                      NFD_ERROR_LIMIT_EXCEEDED);
            // The device limit binds on the Vulkan path only.
            EXPECT_EQ(mesh_with_limits(ctx.get(), asset.get(), 96, 0, kTiny, &refused),
                      vulkan ? NFD_ERROR_LIMIT_EXCEEDED : NFD_SUCCESS);
        }
    }
}

TEST(Limits, GridStopsAtItsMemoryLimit) {
    const AssetPtr asset = make_asset(read_bytes(golden_path("milk_udf_w16_c16", ".nfc")));  // colour
    const ContextPtr ctx = cpu_context();
    nfd_grid_options go{};
    go.struct_size = sizeof go;
    go.resolution = 128;
    nfd_grid *unlimited = nullptr, *limited = nullptr, *refused = nullptr;
    ASSERT_EQ(nfd_grid_extract(ctx.get(), asset.get(), &go, &unlimited), NFD_SUCCESS);
    go.max_host_bytes = kAmple;
    ASSERT_EQ(nfd_grid_extract(ctx.get(), asset.get(), &go, &limited), NFD_SUCCESS);
    nfd_grid_voxels a{}, b{};
    ASSERT_EQ(nfd_grid_get_voxels(unlimited, &a), NFD_SUCCESS);
    ASSERT_EQ(nfd_grid_get_voxels(limited, &b), NFD_SUCCESS);
    ASSERT_EQ(a.count, b.count);
    EXPECT_TRUE(std::equal(a.values, a.values + a.count, b.values));
    go.max_host_bytes = kTiny;
    EXPECT_EQ(nfd_grid_extract(ctx.get(), asset.get(), &go, &refused), NFD_ERROR_LIMIT_EXCEEDED);
    EXPECT_EQ(refused, nullptr);
    nfd_grid_destroy(unlimited);
    nfd_grid_destroy(limited);
}

// A queue job honours its own limits: it fails with LIMIT_EXCEEDED, and the queue goes on.
TEST(Limits, QueueJobFailsAtItsMemoryLimit) {
    const AssetPtr asset = make_asset(read_bytes(golden_path("bunny_sdf_w16", ".nfc")));
    const ContextPtr ctx = cpu_context();
    nfd_queue* q = nullptr;
    ASSERT_EQ(nfd_queue_create(ctx.get(), nullptr, &q), NFD_SUCCESS);
    for (uint64_t limit : {kTiny, kAmple}) {
        nfd_mesh_options mo{};
        mo.struct_size = sizeof mo;
        mo.resolution = 96;
        mo.max_host_bytes = limit;
        MeshPtr mesh;
        nfd_job_status s = NFD_JOB_QUEUED;
        const nfd_result r = run_job(q, asset.get(), mo, &mesh, &s);
        if (limit == kTiny) {
            EXPECT_EQ(s, NFD_JOB_FAILED);
            EXPECT_EQ(r, NFD_ERROR_LIMIT_EXCEEDED);
        } else {
            EXPECT_EQ(s, NFD_JOB_DONE);
            EXPECT_EQ(r, NFD_SUCCESS);
        }
    }
    nfd_queue_destroy(q);
}

}  // namespace
}  // namespace nfd::test
