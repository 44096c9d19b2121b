// The ABI promises of nfdecode.h: option structs grow by struct_size, the runtime version matches
// the header. The structs below are frozen copies of the 0.2 layouts, as a program built against
// the 0.2 header passes them: they must keep working however the library's structs grow.
#include <gtest/gtest.h>
#include <nfdecode/nfdecode.h>

#include <atomic>
#include <cstdint>
#include <cstring>

#include "test_util.h"

namespace nfd::test {
namespace {

namespace v0_2 {
struct context_options {
    uint32_t struct_size;
    nfd_device_kind device;
    const nfd_vulkan_device* adopt;
    uint32_t cpu_threads;
    int enable_validation;
};
struct mesh_options {
    uint32_t struct_size;
    uint32_t resolution;
};
struct extraction_options {
    uint32_t struct_size;
    uint32_t resolution;
    uint32_t mesh_levels;
};
struct extraction_level {
    uint32_t struct_size;
    uint32_t resolution;
    uint32_t index;
    int done;
    uint64_t points_evaluated;
    uint64_t gradients_evaluated;
    uint64_t next_host_bytes;
    uint64_t next_device_bytes;
};
struct job_options {
    uint32_t struct_size;
    int32_t priority;
    nfd_job_callback callback;
    void* user_data;
};
}  // namespace v0_2

// A CPU context and a closed blob's asset.
struct AbiOnBlob : ::testing::Test {
    nfd_context* ctx = nullptr;
    nfd_asset* asset = nullptr;
    void SetUp() override {
        nfd_context_options co{};
        co.struct_size = sizeof co;
        co.device = NFD_DEVICE_CPU;
        ASSERT_EQ(nfd_context_create(&co, &ctx), NFD_SUCCESS);
        const Bytes b = geom_file(closed_blob());
        ASSERT_EQ(nfd_asset_create(b.data(), b.size(), &asset), NFD_SUCCESS);
    }
    void TearDown() override {
        nfd_asset_destroy(asset);
        nfd_context_destroy(ctx);
    }
};

// A 0.2 job's options: read by struct_size, mesh_levels taken as 0 (the final level only): one
// callback, DONE, with the final mesh. A newer caller's job progress struct is written only as
// far as it covers.
TEST_F(AbiOnBlob, JobOptionsKeepTheirLayout) {
    nfd_queue* q = nullptr;
    ASSERT_EQ(nfd_queue_create(ctx, nullptr, &q), NFD_SUCCESS);
    std::atomic<int> calls{0}, done{0};
    struct Count {
        std::atomic<int>*calls, *done;
    } count{&calls, &done};
    const v0_2::job_options old_options{
        sizeof(v0_2::job_options), 0,
        [](nfd_job*, nfd_job_status s, void* user) {
            auto* c = static_cast<Count*>(user);
            ++*c->calls;
            *c->done += s == NFD_JOB_DONE;
        },
        &count};
    nfd_mesh_options mo{};
    mo.struct_size = sizeof mo;
    mo.resolution = 128;  // ladder 32, 64, 128
    nfd_job* job = nullptr;
    ASSERT_EQ(nfd_queue_submit(q, asset, &mo, reinterpret_cast<const nfd_job_options*>(&old_options),
                               &job),
              NFD_SUCCESS);
    ASSERT_EQ(nfd_job_wait(job, UINT64_MAX), NFD_JOB_DONE);
    struct {
        nfd_job_progress known;
        uint32_t unknown;
    } newer{};
    newer.known.struct_size = sizeof newer;
    newer.unknown = 0xABCD;
    ASSERT_EQ(nfd_job_get_progress(job, &newer.known), NFD_SUCCESS);
    EXPECT_EQ(newer.known.struct_size, sizeof newer);
    EXPECT_EQ(newer.known.levels_done, 3u);
    EXPECT_EQ(newer.known.newest_mesh_resolution, 128u);
    EXPECT_EQ(newer.unknown, 0xABCDu);
    nfd_job_progress small{};
    small.struct_size = 4;
    EXPECT_EQ(nfd_job_get_progress(job, &small), NFD_ERROR_INVALID_ARGUMENT);
    nfd_mesh* mesh = nullptr;
    ASSERT_EQ(nfd_job_take_mesh(job, &mesh), NFD_SUCCESS);
    EXPECT_NE(mesh, nullptr);
    nfd_mesh_destroy(mesh);
    nfd_job_destroy(job);
    nfd_queue_destroy(q);
    EXPECT_EQ(calls.load(), 1);
    EXPECT_EQ(done.load(), 1);
}

// The extraction's option struct is read by struct_size, and its output struct written only as
// far as the caller's struct_size says: a newer caller's extra fields are left alone.
TEST_F(AbiOnBlob, ExtractionStructsKeepTheirLayouts) {
    const v0_2::extraction_options old_options{sizeof(v0_2::extraction_options), 64, 0b10};
    nfd_extraction* ex = nullptr;
    ASSERT_EQ(nfd_extraction_create(ctx, asset,
                                    reinterpret_cast<const nfd_extraction_options*>(&old_options),
                                    &ex),
              NFD_SUCCESS);
    struct {
        v0_2::extraction_level known;
        uint32_t unknown[2];
    } newer{};
    newer.known.struct_size = sizeof newer;
    newer.unknown[0] = newer.unknown[1] = 0xABCD;
    nfd_mesh* mesh = nullptr;
    ASSERT_EQ(nfd_extraction_step(ex, &mesh, reinterpret_cast<nfd_extraction_level*>(&newer)),
              NFD_SUCCESS);
    EXPECT_EQ(mesh, nullptr);  // 32 is not asked for
    EXPECT_EQ(newer.known.struct_size, sizeof newer);
    EXPECT_EQ(newer.known.resolution, 32u);
    EXPECT_GT(newer.known.points_evaluated, 0u);
    EXPECT_EQ(newer.unknown[0], 0xABCDu);
    EXPECT_EQ(newer.unknown[1], 0xABCDu);
    v0_2::extraction_level old_level{sizeof(v0_2::extraction_level), 0, 0, 0, 0, 0, 0, 0};
    ASSERT_EQ(nfd_extraction_step(ex, &mesh, reinterpret_cast<nfd_extraction_level*>(&old_level)),
              NFD_SUCCESS);
    EXPECT_NE(mesh, nullptr);
    EXPECT_EQ(old_level.resolution, 64u);
    EXPECT_NE(old_level.done, 0);
    nfd_mesh_destroy(mesh);
    nfd_extraction_destroy(ex);
}

TEST(Abi, RuntimeVersionIsTheHeaders) {
    EXPECT_EQ(nfd_version(), uint32_t(NFD_VERSION));
    EXPECT_EQ(NFD_VERSION >> 16, uint32_t(NFD_VERSION_MAJOR));
}

TEST(Abi, OldLayoutsNewLayoutsAndZeroSizeAgree) {
    v0_2::context_options old_context{sizeof(v0_2::context_options), NFD_DEVICE_CPU, nullptr, 1, 0};
    nfd_context* ctx = nullptr;
    ASSERT_EQ(nfd_context_create(reinterpret_cast<const nfd_context_options*>(&old_context), &ctx),
              NFD_SUCCESS);
    EXPECT_EQ(nfd_context_device_kind(ctx), NFD_DEVICE_CPU);
    const float center[3] = {0, 0, 0};
    const Bytes b = geom_file(closed_blob(1.0f, center));
    nfd_asset* asset = nullptr;
    ASSERT_EQ(nfd_asset_create(b.data(), b.size(), &asset), NFD_SUCCESS);

    auto triangles = [&](const void* options) {
        nfd_mesh* mesh = nullptr;
        EXPECT_EQ(nfd_mesh_extract(ctx, asset, static_cast<const nfd_mesh_options*>(options), &mesh),
                  NFD_SUCCESS);
        nfd_mesh_data d{};
        nfd_mesh_get_data(mesh, &d);
        nfd_mesh_destroy(mesh);
        return d.triangle_count;
    };
    const v0_2::mesh_options old_mesh{sizeof(v0_2::mesh_options), 48};
    const v0_2::mesh_options zero_size{0, 48};  // `= {0}` then a field: read as the 0.2 layout
    nfd_mesh_options current{};
    current.struct_size = sizeof current;
    current.resolution = 48;
    const size_t expected = triangles(&current);
    EXPECT_GT(expected, 100u);
    EXPECT_EQ(triangles(&old_mesh), expected);
    EXPECT_EQ(triangles(&zero_size), expected);

    // A newer header's struct: fields this library does not know are accepted while zero.
    struct {
        nfd_mesh_options known;
        uint32_t unknown[4];
    } newer{};
    newer.known = current;
    newer.known.struct_size = sizeof newer;
    EXPECT_EQ(triangles(&newer), expected);
    newer.unknown[2] = 1;
    nfd_mesh* mesh = reinterpret_cast<nfd_mesh*>(0x1);
    EXPECT_EQ(nfd_mesh_extract(ctx, asset, &newer.known, &mesh), NFD_ERROR_INVALID_ARGUMENT);
    EXPECT_EQ(mesh, nullptr);
    // Smaller than the first sized layout: not a struct this library can read.
    nfd_mesh_options tiny = current;
    tiny.struct_size = 2;
    EXPECT_EQ(nfd_mesh_extract(ctx, asset, &tiny, &mesh), NFD_ERROR_INVALID_ARGUMENT);

    nfd_asset_destroy(asset);
    nfd_context_destroy(ctx);
}

}  // namespace
}  // namespace nfd::test
