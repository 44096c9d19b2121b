// Progressive extraction (nfdecode.h, "Progressive extraction"; progressive.h) on the CPU and,
// where a Vulkan device exists, on it: every level's mesh byte-identical to the one-shot decode at
// that level's resolution where that is exact, the values evaluated once over all levels, early
// stops, invalid options, and the host-memory bound of the next step against a counting allocator.
#include <gtest/gtest.h>
#include <nfdecode/nfdecode.h>

#include <cstdlib>
#include <cstring>

#include "alloc_tracking.h"
#include "extract.h"
#include "progressive.h"
#if NFD_WITH_VULKAN
#include "gpu/gpu_decode.h"
#endif
#include "test_util.h"

namespace nfd::test {
namespace {

struct Asset {
    nfd_asset* handle = nullptr;
    explicit Asset(const Bytes& bytes) {
        EXPECT_EQ(nfd_asset_create(bytes.data(), bytes.size(), &handle), NFD_SUCCESS);
    }
    ~Asset() { nfd_asset_destroy(handle); }
};

struct Context {
    nfd_context* handle = nullptr;
    explicit Context(nfd_device_kind kind) {
        nfd_context_options o{};
        o.struct_size = sizeof o;
        o.device = kind;
        if (nfd_context_create(&o, &handle) != NFD_SUCCESS) handle = nullptr;
    }
    ~Context() { nfd_context_destroy(handle); }
};

Bytes udf_blob() {
    const float center[3] = {1.0f, -2.0f, 0.5f};
    GeomSpec blob = closed_blob(3.0f, center);
    blob.field_type = 1;
    blob.output = 1;
    return geom_file(blob);
}

// The assets every device is tested on: golden vectors (SDF and UDF) and the synthetic blob.
std::vector<std::pair<std::string, Bytes>> assets() {
    std::vector<std::pair<std::string, Bytes>> out;
    for (const std::string& name : golden_names())
        out.emplace_back(name, read_bytes(golden_path(name, ".nfc")));
    out.emplace_back("blob_sdf", geom_file(closed_blob(2.0f)));
    out.emplace_back("blob_udf", udf_blob());
    return out;
}

void expect_same_arrays(const nfd_mesh* a, const nfd_mesh* b) {
    nfd_mesh_data x, y;
    ASSERT_EQ(nfd_mesh_get_data(a, &x), NFD_SUCCESS);
    ASSERT_EQ(nfd_mesh_get_data(b, &y), NFD_SUCCESS);
    ASSERT_EQ(x.vertex_count, y.vertex_count);
    ASSERT_EQ(x.triangle_count, y.triangle_count);
    EXPECT_EQ(std::memcmp(x.positions, y.positions, 12 * x.vertex_count), 0);
    EXPECT_EQ(std::memcmp(x.normals, y.normals, 12 * x.vertex_count), 0);
    EXPECT_EQ(std::memcmp(x.indices, y.indices, 12 * x.triangle_count), 0);
}

nfd_mesh* one_shot(nfd_context* ctx, const nfd_asset* asset, uint32_t resolution,
                   int sample_band = 0) {
    nfd_mesh_options mo{};
    mo.struct_size = sizeof mo;
    mo.resolution = resolution;
    mo.sample_band = sample_band;
    nfd_mesh* mesh = nullptr;
    EXPECT_EQ(nfd_mesh_extract(ctx, asset, &mo, &mesh), NFD_SUCCESS);
    return mesh;
}

std::vector<uint32_t> ladder(uint32_t resolution) {
    uint32_t r[NFD_MAX_LADDER_LEVELS], n = 0;
    EXPECT_EQ(nfd_extraction_ladder(resolution, r, NFD_MAX_LADDER_LEVELS, &n), NFD_SUCCESS);
    return std::vector<uint32_t>(r, r + n);
}

// Runs a progressive extraction at `resolution` meshing every level; each level's mesh equals the
// one-shot at its resolution when `exact(level resolution)`, the final always; the new values of all
// steps add up to the one-shot's at `resolution`.
void expect_progressive_equals_one_shot(nfd_context* ctx, const nfd_asset* asset,
                                        uint32_t resolution) {
    const std::vector<uint32_t> rungs = ladder(resolution);
    nfd_extraction_options eo{};
    eo.struct_size = sizeof eo;
    eo.resolution = resolution;
    nfd_extraction* ex = nullptr;
    ASSERT_EQ(nfd_extraction_create(ctx, asset, &eo, &ex), NFD_SUCCESS);
    uint64_t values = 0;
    for (size_t i = 0; i < rungs.size(); ++i) {
        SCOPED_TRACE("level " + std::to_string(rungs[i]));
        nfd_extraction_level info{};
        info.struct_size = sizeof info;
        nfd_mesh* mesh = nullptr;
        ASSERT_EQ(nfd_extraction_step(ex, &mesh, &info), NFD_SUCCESS);
        ASSERT_NE(mesh, nullptr);
        EXPECT_EQ(info.resolution, rungs[i]);
        EXPECT_EQ(info.index, i);
        EXPECT_EQ(info.done != 0, i + 1 == rungs.size());
        values += info.points_evaluated;
        if (resolution % rungs[i] == 0) {  // r / 2^k exact: that decode's own finest level
            nfd_mesh* reference = one_shot(ctx, asset, rungs[i]);
            expect_same_arrays(mesh, reference);
            nfd_decode_stats a, b;
            nfd_mesh_get_stats(mesh, &a);
            nfd_mesh_get_stats(reference, &b);
            EXPECT_EQ(a.active_cells, b.active_cells);
            if (i + 1 == rungs.size()) {
                EXPECT_EQ(values, b.points_evaluated);  // never re-evaluated
                EXPECT_EQ(a.points_evaluated, b.points_evaluated);
            }
            nfd_mesh_destroy(reference);
        }
        nfd_mesh_destroy(mesh);
    }
    nfd_mesh* mesh = nullptr;
    EXPECT_EQ(nfd_extraction_step(ex, &mesh, nullptr), NFD_ERROR_INVALID_ARGUMENT);  // past done
    EXPECT_EQ(mesh, nullptr);
    nfd_extraction_destroy(ex);
}

class Progressive : public ::testing::TestWithParam<nfd_device_kind> {
protected:
    void SetUp() override {
        ctx_ = std::make_unique<Context>(GetParam());
        if (ctx_->handle) return;
        const char* required = std::getenv("NFD_REQUIRE_VULKAN");
        if (required && *required && *required != '0') FAIL() << "no Vulkan device";
        GTEST_SKIP() << "no Vulkan device";
    }
    nfd_context* ctx() { return ctx_->handle; }
    std::unique_ptr<Context> ctx_;
};

TEST(ProgressiveLadder, FollowsTheGridLevels) {
    EXPECT_EQ(ladder(256), (std::vector<uint32_t>{32, 64, 128, 256}));
    EXPECT_EQ(ladder(0), ladder(NFD_DEFAULT_RESOLUTION));
    EXPECT_EQ(ladder(200), (std::vector<uint32_t>{50, 100, 200}));
    EXPECT_EQ(ladder(130), (std::vector<uint32_t>{33, 65, 130}));
    EXPECT_EQ(ladder(48), (std::vector<uint32_t>{48}));
    EXPECT_EQ(ladder(1024), (std::vector<uint32_t>{32, 64, 128, 256, 512, 1024}));
    uint32_t r[2], n = 0;
    EXPECT_EQ(nfd_extraction_ladder(256, r, 2, &n), NFD_ERROR_INVALID_ARGUMENT);
    EXPECT_EQ(n, 4u);
    EXPECT_EQ(r[1], 64u);
    EXPECT_EQ(nfd_extraction_ladder(256, nullptr, 0, &n), NFD_ERROR_INVALID_ARGUMENT);
    EXPECT_EQ(nfd_extraction_ladder(256, r, 2, nullptr), NFD_ERROR_INVALID_ARGUMENT);
    EXPECT_EQ(nfd_extraction_ladder(4, r, 2, &n), NFD_ERROR_LIMIT_EXCEEDED);
    EXPECT_EQ(nfd_extraction_ladder(NFD_MAX_RESOLUTION + 1, r, 2, &n), NFD_ERROR_LIMIT_EXCEEDED);
}

TEST_P(Progressive, EveryLevelEqualsTheOneShotDecode) {
    for (const auto& [name, bytes] : assets()) {
        SCOPED_TRACE(name);
        Asset asset(bytes);
        expect_progressive_equals_one_shot(ctx(), asset.handle, 128);
    }
}

// Levels of a resolution that is not 32 * 2^k: 200's are all exact (50, 100, 200), 130's coarse
// ones are not (33, 65): only its final level has a one-shot twin.
TEST_P(Progressive, NonPowerOfTwoResolutions) {
    for (const char* name : {"bunny_sdf_w16", "tshirt_udf_w16"}) {
        SCOPED_TRACE(name);
        Asset asset(read_bytes(golden_path(name, ".nfc")));
        expect_progressive_equals_one_shot(ctx(), asset.handle, 200);
        expect_progressive_equals_one_shot(ctx(), asset.handle, 130);
    }
}

TEST_P(Progressive, MeshesOnlyTheLevelsAsked) {
    Asset asset(read_bytes(golden_path("bunny_sdf_w16", ".nfc")));
    nfd_extraction_options eo{};
    eo.struct_size = sizeof eo;
    eo.resolution = 128;
    eo.mesh_levels = 0b101;  // 32 and 128, not 64
    nfd_extraction* ex = nullptr;
    ASSERT_EQ(nfd_extraction_create(ctx(), asset.handle, &eo, &ex), NFD_SUCCESS);
    for (int i = 0; i < 3; ++i) {
        nfd_mesh* mesh = nullptr;
        ASSERT_EQ(nfd_extraction_step(ex, &mesh, nullptr), NFD_SUCCESS);
        EXPECT_EQ(mesh != nullptr, i != 1) << i;
        if (i == 2) {
            nfd_mesh* reference = one_shot(ctx(), asset.handle, 128);
            expect_same_arrays(mesh, reference);
            nfd_mesh_destroy(reference);
        }
        nfd_mesh_destroy(mesh);
    }
    nfd_extraction_destroy(ex);
}

// A field far steeper than the keep rule's margin (no fit of a shape): a sphere of radius 0.04
// around the centre of a cell of the 16 probe, whose corners read about 30 (the blob's field times
// 3000). A ladder to 128 samples its coarsest level (32) through that probe (nfdecode.h, "The
// meshes"), which leaves the cell out, where the decode at 32 evaluates every vertex and finds the
// sphere at the one inside it. The level meshes only cells whose corners were all evaluated, on
// every device (the GPU lists only those; the CPU skips the others), as many triangles on the CPU
// as here; the final level is still the one-shot's.
TEST_P(Progressive, ASteepFieldsCoarsestLevelMeshesOnlyEvaluatedCells) {
    GeomSpec steep = offset_blob(0.0625f);  // a probe cell's centre, a vertex of the 32 level
    const double threshold = 3.0 - 2.0 * 0.04 * 0.04;  // sum_j cos(2 x_j) > it: |x| < 0.04
    steep.steps[3] = float(0.01 * threshold / 32767);   // layer 1's bias, a * T
    steep.steps[4] *= 3000.0f;                          // the output layer's weights
    Asset asset(geom_file(steep));
    Context cpu(NFD_DEVICE_CPU);
    auto coarsest_triangles = [&](nfd_context* context) -> size_t {
        nfd_extraction_options eo{};
        eo.struct_size = sizeof eo;
        eo.resolution = 128;
        eo.mesh_levels = 0b101;  // 32 and 128
        nfd_extraction* ex = nullptr;
        EXPECT_EQ(nfd_extraction_create(context, asset.handle, &eo, &ex), NFD_SUCCESS);
        nfd_mesh* mesh = nullptr;
        EXPECT_EQ(nfd_extraction_step(ex, &mesh, nullptr), NFD_SUCCESS);
        nfd_mesh_data d{};
        EXPECT_EQ(nfd_mesh_get_data(mesh, &d), NFD_SUCCESS);
        nfd_mesh_destroy(mesh);
        for (int i = 0; i < 2; ++i) {
            EXPECT_EQ(nfd_extraction_step(ex, &mesh, nullptr), NFD_SUCCESS);
            if (i == 1) {
                nfd_mesh* reference = one_shot(context, asset.handle, 128);
                expect_same_arrays(mesh, reference);
                nfd_mesh_destroy(reference);
            }
            nfd_mesh_destroy(mesh);
        }
        nfd_extraction_destroy(ex);
        return d.triangle_count;
    };
    const size_t here = coarsest_triangles(ctx());
    nfd_mesh* dense = one_shot(ctx(), asset.handle, 32);
    nfd_mesh_data d{};
    ASSERT_EQ(nfd_mesh_get_data(dense, &d), NFD_SUCCESS);
    nfd_mesh_destroy(dense);
    EXPECT_GT(d.triangle_count, 0u);
    EXPECT_EQ(here, 0u);
    EXPECT_EQ(here, coarsest_triangles(cpu.handle));
}

TEST_P(Progressive, StopsAtAnyLevel) {
    for (const char* name : {"bunny_sdf_w16", "tshirt_udf_w16"}) {
        Asset asset(read_bytes(golden_path(name, ".nfc")));
        nfd_extraction* ex = nullptr;
        ASSERT_EQ(nfd_extraction_create(ctx(), asset.handle, nullptr, &ex), NFD_SUCCESS);
        nfd_extraction_destroy(ex);  // before any step
        ASSERT_EQ(nfd_extraction_create(ctx(), asset.handle, nullptr, &ex), NFD_SUCCESS);
        for (int i = 0; i < 2; ++i) {
            nfd_mesh* mesh = nullptr;
            ASSERT_EQ(nfd_extraction_step(ex, &mesh, nullptr), NFD_SUCCESS);
            EXPECT_NE(mesh, nullptr);
            nfd_mesh_destroy(mesh);
        }
        nfd_extraction_destroy(ex);  // after level 1 of 256's four
    }
}

TEST_P(Progressive, RejectsInvalidOptions) {
    Asset asset(geom_file(closed_blob()));
    nfd_extraction* ex = reinterpret_cast<nfd_extraction*>(&asset);
    nfd_extraction_options eo{};
    eo.struct_size = sizeof eo;
    EXPECT_EQ(nfd_extraction_create(nullptr, asset.handle, &eo, &ex), NFD_ERROR_INVALID_ARGUMENT);
    EXPECT_EQ(ex, nullptr);
    EXPECT_EQ(nfd_extraction_create(ctx(), nullptr, &eo, &ex), NFD_ERROR_INVALID_ARGUMENT);
    EXPECT_EQ(nfd_extraction_create(ctx(), asset.handle, &eo, nullptr), NFD_ERROR_INVALID_ARGUMENT);
    eo.resolution = NFD_MAX_RESOLUTION + 1;
    EXPECT_EQ(nfd_extraction_create(ctx(), asset.handle, &eo, &ex), NFD_ERROR_LIMIT_EXCEEDED);
    eo.resolution = 256;
    eo.mesh_levels = 0b0111;  // without the final level
    EXPECT_EQ(nfd_extraction_create(ctx(), asset.handle, &eo, &ex), NFD_ERROR_INVALID_ARGUMENT);
    eo.mesh_levels = 0b11000;  // a level past the ladder (256 has four)
    EXPECT_EQ(nfd_extraction_create(ctx(), asset.handle, &eo, &ex), NFD_ERROR_INVALID_ARGUMENT);
    eo.struct_size = 4;  // shorter than the first layout
    eo.mesh_levels = 0;
    EXPECT_EQ(nfd_extraction_create(ctx(), asset.handle, &eo, &ex), NFD_ERROR_INVALID_ARGUMENT);

    eo.struct_size = 0;  // `= {0}` then fields: the first layout
    eo.resolution = 64;
    ASSERT_EQ(nfd_extraction_create(ctx(), asset.handle, &eo, &ex), NFD_SUCCESS);
    nfd_mesh* mesh = nullptr;
    nfd_extraction_level info{};
    info.struct_size = 8;
    EXPECT_EQ(nfd_extraction_step(ex, &mesh, &info), NFD_ERROR_INVALID_ARGUMENT);
    EXPECT_EQ(nfd_extraction_step(ex, nullptr, nullptr), NFD_ERROR_INVALID_ARGUMENT);
    EXPECT_EQ(nfd_extraction_step(nullptr, &mesh, nullptr), NFD_ERROR_INVALID_ARGUMENT);
    info.struct_size = 0;
    EXPECT_EQ(nfd_extraction_step(ex, &mesh, &info), NFD_SUCCESS);  // 32
    EXPECT_EQ(info.resolution, 32u);
    EXPECT_EQ(info.struct_size, 0u);
    nfd_mesh_destroy(mesh);
    nfd_extraction_destroy(ex);
    nfd_extraction_destroy(nullptr);
}

// Gradient evaluations per level of a progressive extraction, every level meshed.
std::vector<uint64_t> progressive_gradients(nfd_context* ctx, const nfd_asset* asset,
                                            uint32_t resolution) {
    nfd_extraction_options eo{};
    eo.struct_size = sizeof eo;
    eo.resolution = resolution;
    nfd_extraction* ex = nullptr;
    EXPECT_EQ(nfd_extraction_create(ctx, asset, &eo, &ex), NFD_SUCCESS);
    std::vector<uint64_t> per_level;
    nfd_extraction_level info{};
    do {
        info.struct_size = sizeof info;
        nfd_mesh* mesh = nullptr;
        if (nfd_extraction_step(ex, &mesh, &info) != NFD_SUCCESS) {
            ADD_FAILURE() << "step";
            break;
        }
        nfd_mesh_destroy(mesh);
        per_level.push_back(info.gradients_evaluated);
    } while (!info.done);
    nfd_extraction_destroy(ex);
    return per_level;
}

// A UDF level copies the gradients its even corners had on the level above (same f32 points)
// instead of evaluating them again, on the CPU (grid.cpp) and on the Vulkan path (udf_gradient_
// merge.comp): fewer gradient evaluations than the one-shot decodes of its levels together, the
// final level fewer than its one-shot, whose mesh it still equals (EveryLevelEqualsTheOneShot-
// Decode), and the same count per level on every device but for the second level on Vulkan:
// there the coarsest level's gradients are the host's (levels.h, HostTop), which the next level
// evaluates again on the device, as its one-shot decode does.
TEST_P(Progressive, UdfLevelsReuseTheGradientsAbove) {
    Context cpu(NFD_DEVICE_CPU);
    for (const char* name : {"tshirt_udf_w16", "bunny_scans_udf_w16"}) {
        SCOPED_TRACE(name);
        const Bytes bytes = read_bytes(golden_path(name, ".nfc"));
        const Geometry g = parse_or_throw(bytes);
        uint64_t one_shots = 0, final_one_shot = 0;
        for (uint32_t r : {32u, 64u, 128u}) {
            MeshData mesh;
            ExtractStats stats;
            ASSERT_EQ(extract_mesh_cpu(g, r, &mesh, &stats), NFD_SUCCESS);
            one_shots += stats.gradients_evaluated;
            final_one_shot = stats.gradients_evaluated;
        }
        Asset asset(bytes);
        const std::vector<uint64_t> here = progressive_gradients(ctx(), asset.handle, 128);
        ASSERT_EQ(here.size(), 3u);
        EXPECT_LT(here[0] + here[1] + here[2], one_shots);
        EXPECT_LT(here[2], final_one_shot);
        EXPECT_GT(here[2], final_one_shot / 2);
        const std::vector<uint64_t> on_cpu = progressive_gradients(cpu.handle, asset.handle, 128);
        ASSERT_EQ(on_cpu.size(), 3u);
        EXPECT_EQ(here[0], on_cpu[0]);
        EXPECT_GE(here[1], on_cpu[1]);
        EXPECT_EQ(here[2], on_cpu[2]);
    }
}

// The Vulkan path's top step evaluates only the vertices of the coarsest level, as the CPU does,
// also where that level's cell count is odd (33 of 33, 66 and 130) and the level above it has
// vertices past it: the same count of values on both. The levels below follow the keep rule on
// both with sample_band (the Vulkan path always does, grid.h).
TEST_P(Progressive, CountsValuesAsTheCpuDoes) {
    Context cpu(NFD_DEVICE_CPU);
    Asset asset(read_bytes(golden_path("tshirt_udf_w16", ".nfc")));
    for (uint32_t r : {33u, 66u, 130u, 256u}) {
        nfd_mesh* here = one_shot(ctx(), asset.handle, r, 1);
        nfd_mesh* reference = one_shot(cpu.handle, asset.handle, r, 1);
        nfd_decode_stats a, b;
        nfd_mesh_get_stats(here, &a);
        nfd_mesh_get_stats(reference, &b);
        EXPECT_EQ(a.points_evaluated, b.points_evaluated) << r;
        EXPECT_EQ(a.active_cells, b.active_cells) << r;
        nfd_mesh_destroy(here);
        nfd_mesh_destroy(reference);
    }
}

INSTANTIATE_TEST_SUITE_P(Devices, Progressive,
#if NFD_WITH_VULKAN
                         ::testing::Values(NFD_DEVICE_CPU, NFD_DEVICE_VULKAN),
#else
                         ::testing::Values(NFD_DEVICE_CPU),
#endif
                         [](const auto& info) {
                             return info.param == NFD_DEVICE_CPU ? "Cpu" : "Vulkan";
                         });

// What a step reports it will allocate bounds what the next step's peak adds to the live host
// bytes, on the CPU path, SDF and UDF, every level meshed (the largest case).
// Hostile values that pass the CRC (the accepted flips of every 41st byte of a small SDF and UDF
// network's GEOM payload): every level of a progressive extraction ends in a success with a
// finite mesh or an error code, never a crash (CPU path, ladder 32, 64).
// Damaged weights that pass the CRC, through both schedules (surface following, the band) of an
// SDF and of a UDF, at 64 (one refined level) and 75 (an odd level above: midpoints at its last
// vertex).
TEST(ProgressiveCpu, AcceptedDamageGivesFiniteLevelsOrErrors) {
    for (uint8_t field : {uint8_t(0), uint8_t(1)})
    for (bool band : {false, true}) {
        size_t meshed = 0;
        for_each_accepted_damage(
            geom_payload(random_siren(8, 8, 11, field)), 41, {0x80, 0xFF},
            [&](size_t i, const Geometry& g) {
                const uint32_t resolution = i % 2 ? 75 : 64;
                const std::unique_ptr<Extraction> ex =
                    make_extraction_cpu(g, resolution, 0b11, 1, band);
                for (bool done = false; !done;) {
                    MeshData m;
                    ExtractStats stats;
                    LevelReport report;
                    if (ex->step(&m, &stats, &report) != NFD_SUCCESS) break;
                    ASSERT_TRUE(is_finite_mesh(m)) << i;
                    meshed += m.triangle_count() > 0;
                    done = report.done;
                }
            });
        EXPECT_GT(meshed, 0u) << int(field) << " band " << band;
    }
}

TEST(ProgressiveMemory, NextStepBoundHoldsOnTheCpu) {
    for (const std::string name : {"bunny_sdf_w32", "tshirt_udf_w16"}) {
        SCOPED_TRACE(name);
        Context ctx(NFD_DEVICE_CPU);
        Asset asset(read_bytes(golden_path(name, ".nfc")));
        nfd_extraction_options eo{};
        eo.struct_size = sizeof eo;
        eo.resolution = 256;
        nfd_extraction* ex = nullptr;
        ASSERT_EQ(nfd_extraction_create(ctx.handle, asset.handle, &eo, &ex), NFD_SUCCESS);
        std::vector<nfd_mesh*> meshes;  // kept: the bound counts the mesh a step returns
        uint64_t bound = 0;
        for (int i = 0;; ++i) {
            const int64_t before = g_live_bytes.load();
            g_peak_live_bytes = before;
            nfd_extraction_level info{};
            info.struct_size = sizeof info;
            meshes.push_back(nullptr);
            ASSERT_EQ(nfd_extraction_step(ex, &meshes.back(), &info), NFD_SUCCESS);
            const uint64_t used = uint64_t(g_peak_live_bytes.load() - before);
            if (i > 0) {
                EXPECT_LE(used, bound) << "level " << info.resolution;
                EXPECT_GT(used, 0u);
                ::testing::Test::RecordProperty(name + "_bound_over_peak_r" +
                                                    std::to_string(info.resolution),
                                                std::to_string(double(bound) / double(used)));
            }
            EXPECT_EQ(info.next_device_bytes, 0u);
            if (info.done) {
                EXPECT_EQ(info.next_host_bytes, 0u);
                break;
            }
            bound = info.next_host_bytes;
        }
        for (nfd_mesh* m : meshes) nfd_mesh_destroy(m);
        nfd_extraction_destroy(ex);
    }
}

#if NFD_WITH_VULKAN
// The device bound of the next step against the device memory the Vulkan path's buffers hold at
// the step's peak, SDF and UDF, every level meshed.
TEST(ProgressiveMemory, NextStepDeviceBoundHoldsOnVulkan) {
    std::unique_ptr<gpu::Device> device;
    if (gpu::create_device(nullptr, false, &device) != NFD_SUCCESS) {
        const char* required = std::getenv("NFD_REQUIRE_VULKAN");
        if (required && *required && *required != '0') FAIL() << "no Vulkan device";
        GTEST_SKIP() << "no Vulkan device";
    }
    for (const std::string name : {"bunny_sdf_w32", "tshirt_udf_w16"}) {
        SCOPED_TRACE(name);
        const Geometry g = parse_or_throw(read_bytes(golden_path(name, ".nfc")));
        std::unique_ptr<Extraction> ex;
        ASSERT_EQ(gpu::make_extraction(*device, g, 256, 0b1111, false, &ex), NFD_SUCCESS);
        std::vector<MeshData> meshes;
        uint64_t bound = 0;
        for (int i = 0;; ++i) {
            gpu::reset_device_memory_peak(*device);
            const uint64_t before = gpu::device_memory(*device).live;
            meshes.emplace_back();
            ExtractStats stats;
            LevelReport report;
            ASSERT_EQ(ex->step(&meshes.back(), &stats, &report), NFD_SUCCESS);
            const uint64_t used = gpu::device_memory(*device).peak - before;
            if (i > 0) {
                EXPECT_LE(used, bound) << "level " << report.cells_per_axis;
                ::testing::Test::RecordProperty(name + "_device_bound_over_peak_r" +
                                                    std::to_string(report.cells_per_axis),
                                                std::to_string(double(bound) / double(used)));
            }
            if (report.done) break;
            bound = report.next_device_bytes;
        }
    }
}
#endif

}  // namespace
}  // namespace nfd::test
