// The public C API: argument checks, defaults of zeroed options, limits, result strings, device
// selection, and the files it writes (read back independently of the writers).
#include <gtest/gtest.h>
#include <nfdecode/nfdecode.h>

#include <cstdio>
#include <cstring>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <set>
#include <unistd.h>

// tinygltf (header-only) reads the .glb files back: an implementation other than the writer's.
#define TINYGLTF_IMPLEMENTATION
#define TINYGLTF_NO_STB_IMAGE
#define TINYGLTF_NO_STB_IMAGE_WRITE
#define TINYGLTF_NO_EXTERNAL_IMAGE
#include <tiny_gltf.h>

#include "export.h"
#include "test_util.h"

namespace nfd::test {
namespace {

const nfd_result kAllResults[] = {
    NFD_SUCCESS,           NFD_ERROR_TRUNCATED,          NFD_ERROR_CORRUPT,
    NFD_ERROR_UNSUPPORTED_VERSION, NFD_ERROR_UNSUPPORTED_FEATURE, NFD_ERROR_INVALID_ARGUMENT,
    NFD_ERROR_LIMIT_EXCEEDED, NFD_ERROR_OUT_OF_MEMORY,  NFD_ERROR_DEVICE_UNAVAILABLE,
    NFD_ERROR_DEVICE,      NFD_ERROR_IO,                 NFD_ERROR_INTERNAL,
    NFD_ERROR_CANCELLED,   NFD_ERROR_NOT_READY,          NFD_ERROR_CAPACITY_EXCEEDED};

struct Api : ::testing::Test {
    nfd_context* ctx = nullptr;
    nfd_asset* asset = nullptr;
    nfd_mesh* mesh = nullptr;
    float center[3] = {1.0f, -2.0f, 0.5f};

    void SetUp() override {
        nfd_context_options o = {};
        o.device = NFD_DEVICE_CPU;
        ASSERT_EQ(nfd_context_create(&o, &ctx), NFD_SUCCESS);
        const Bytes b = geom_file(closed_blob(2.0f, center));
        ASSERT_EQ(nfd_asset_create(b.data(), b.size(), &asset), NFD_SUCCESS);
    }
    void TearDown() override {
        nfd_mesh_destroy(mesh);
        nfd_asset_destroy(asset);
        nfd_context_destroy(ctx);
    }
    void extract(uint32_t resolution) {
        nfd_mesh_options mo = {};
        mo.resolution = resolution;
        ASSERT_EQ(nfd_mesh_extract(ctx, asset, &mo, &mesh), NFD_SUCCESS);
    }
    static std::string temp_path(const std::string& name) {
        return (std::filesystem::temp_directory_path() /
                ("nfd_test_" + std::to_string(::getpid()) + "_" + name))
            .string();
    }
};

TEST(ApiResults, StringsAreDistinctAndNeverNull) {
    std::set<std::string> seen;
    for (nfd_result r : kAllResults) {
        const char* s = nfd_result_string(r);
        ASSERT_NE(s, nullptr);
        EXPECT_STRNE(s, "unknown result") << int(r);
        EXPECT_TRUE(seen.insert(s).second) << s;
    }
    EXPECT_STREQ(nfd_result_string(static_cast<nfd_result>(-59)), "unknown result");
    EXPECT_STREQ(nfd_result_string(static_cast<nfd_result>(7)), "unknown result");
}

TEST(ApiResults, ErrorsAreGroupedByRange) {
    for (nfd_result r : {NFD_ERROR_TRUNCATED, NFD_ERROR_CORRUPT, NFD_ERROR_UNSUPPORTED_VERSION,
                         NFD_ERROR_UNSUPPORTED_FEATURE})
        EXPECT_TRUE(r <= -1 && r >= -19);
    for (nfd_result r : {NFD_ERROR_INVALID_ARGUMENT, NFD_ERROR_LIMIT_EXCEEDED, NFD_ERROR_CANCELLED,
                         NFD_ERROR_NOT_READY, NFD_ERROR_CAPACITY_EXCEEDED})
        EXPECT_TRUE(r <= -20 && r >= -39);
    for (nfd_result r : {NFD_ERROR_OUT_OF_MEMORY, NFD_ERROR_DEVICE_UNAVAILABLE, NFD_ERROR_DEVICE,
                         NFD_ERROR_IO})
        EXPECT_TRUE(r <= -40 && r >= -59);
}

TEST(ApiContext, NullAndInvalidArguments) {
    EXPECT_EQ(nfd_context_create(nullptr, nullptr), NFD_ERROR_INVALID_ARGUMENT);
    nfd_context* ctx = reinterpret_cast<nfd_context*>(0x1);
    nfd_context_options o = {};
    const int bogus = 7;  // as a C caller could store it
    std::memcpy(&o.device, &bogus, sizeof bogus);
    EXPECT_EQ(nfd_context_create(&o, &ctx), NFD_ERROR_INVALID_ARGUMENT);
    EXPECT_EQ(ctx, nullptr);  // out handle cleared on failure
    const nfd_vulkan_device adopt = {};
    o.device = NFD_DEVICE_CPU;
    o.adopt = &adopt;
    EXPECT_EQ(nfd_context_create(&o, &ctx), NFD_ERROR_INVALID_ARGUMENT);
    nfd_context_destroy(nullptr);
    EXPECT_EQ(nfd_context_device_kind(nullptr), NFD_DEVICE_AUTO);
    EXPECT_STREQ(nfd_context_device_name(nullptr), "");
}

TEST(ApiContext, DeviceSelection) {
    nfd_context* cpu = nullptr;
    nfd_context_options o = {};
    o.device = NFD_DEVICE_CPU;
    ASSERT_EQ(nfd_context_create(&o, &cpu), NFD_SUCCESS);
    EXPECT_EQ(nfd_context_device_kind(cpu), NFD_DEVICE_CPU);
    EXPECT_STREQ(nfd_context_device_name(cpu), "cpu");
    nfd_context_destroy(cpu);

    // NULL options and zeroed options both mean AUTO, which always yields a working context.
    nfd_context *a = nullptr, *b = nullptr;
    const nfd_context_options zero = {};
    ASSERT_EQ(nfd_context_create(nullptr, &a), NFD_SUCCESS);
    ASSERT_EQ(nfd_context_create(&zero, &b), NFD_SUCCESS);
    EXPECT_EQ(nfd_context_device_kind(a), nfd_context_device_kind(b));
    EXPECT_NE(nfd_context_device_kind(a), NFD_DEVICE_AUTO);
    nfd_context_destroy(a);
    nfd_context_destroy(b);

    nfd_context* vk = nullptr;
    o.device = NFD_DEVICE_VULKAN;
    const nfd_result r = nfd_context_create(&o, &vk);
#if NFD_WITH_VULKAN
    EXPECT_TRUE(r == NFD_SUCCESS || r == NFD_ERROR_DEVICE_UNAVAILABLE) << nfd_result_string(r);
    if (r == NFD_SUCCESS) EXPECT_EQ(nfd_context_device_kind(vk), NFD_DEVICE_VULKAN);
#else
    EXPECT_EQ(r, NFD_ERROR_DEVICE_UNAVAILABLE);  // built without Vulkan: only the CPU exists
    EXPECT_EQ(vk, nullptr);
#endif
    nfd_context_destroy(vk);
}

// nfd_context_get_device_memory: zeros on the CPU; on Vulkan, a decode's buffers in a few
// shared allocations, and after it only what the device caches (the network, the tables).
TEST(ApiContext, DeviceMemory) {
    nfd_device_memory m = {};
    EXPECT_EQ(nfd_context_get_device_memory(nullptr, &m), NFD_ERROR_INVALID_ARGUMENT);
    nfd_context* cpu = nullptr;
    nfd_context_options o = {};
    o.device = NFD_DEVICE_CPU;
    ASSERT_EQ(nfd_context_create(&o, &cpu), NFD_SUCCESS);
    EXPECT_EQ(nfd_context_get_device_memory(cpu, nullptr), NFD_ERROR_INVALID_ARGUMENT);
    for (uint32_t below : {1u, 4u, uint32_t(sizeof(nfd_device_memory) - 1)}) {
        m.struct_size = below;  // below the first layout
        EXPECT_EQ(nfd_context_get_device_memory(cpu, &m), NFD_ERROR_INVALID_ARGUMENT) << below;
    }
    // A newer caller's larger struct: this layout is written, the bytes past it are left alone.
    struct Newer {
        nfd_device_memory known;
        uint64_t later_field;
    } newer;
    std::memset(&newer, 0xA5, sizeof newer);
    newer.known.struct_size = sizeof newer;
    ASSERT_EQ(nfd_context_get_device_memory(cpu, &newer.known), NFD_SUCCESS);
    EXPECT_EQ(newer.known.struct_size, sizeof newer);
    EXPECT_EQ(newer.known.live_bytes + newer.known.allocations_made, 0u);
    EXPECT_EQ(newer.later_field, 0xA5A5A5A5A5A5A5A5ull);
    m = {};  // struct_size 0: this layout
    m.live_bytes = 7;
    ASSERT_EQ(nfd_context_get_device_memory(cpu, &m), NFD_SUCCESS);
    EXPECT_EQ(m.struct_size, 0u);
    EXPECT_EQ(m.live_bytes + m.live_allocations + m.buffers_created + m.allocations_made, 0u);
    nfd_context_destroy(cpu);

    nfd_context* vk = nullptr;
    o.device = NFD_DEVICE_VULKAN;
    if (nfd_context_create(&o, &vk) != NFD_SUCCESS) GTEST_SKIP() << "no Vulkan device";
    const Bytes bytes = read_bytes(golden_path("tshirt_udf_w16", ".nfc"));
    nfd_asset* asset = nullptr;
    ASSERT_EQ(nfd_asset_create(bytes.data(), bytes.size(), &asset), NFD_SUCCESS);
    nfd_device_memory before = {}, after = {};
    before.struct_size = after.struct_size = sizeof(nfd_device_memory);
    ASSERT_EQ(nfd_context_get_device_memory(vk, &before), NFD_SUCCESS);
    nfd_mesh_options mo = {};
    mo.resolution = 128;
    nfd_mesh* mesh = nullptr;
    ASSERT_EQ(nfd_mesh_extract(vk, asset, &mo, &mesh), NFD_SUCCESS);
    ASSERT_EQ(nfd_context_get_device_memory(vk, &after), NFD_SUCCESS);
    EXPECT_EQ(after.struct_size, sizeof(nfd_device_memory));
    const uint64_t buffers = after.buffers_created - before.buffers_created;
    const uint64_t allocations = after.allocations_made - before.allocations_made;
    EXPECT_GT(buffers, 30u);
    EXPECT_LT(3 * allocations, buffers);
    EXPECT_GE(after.live_allocations, 1u);  // the cached network, the tables
    EXPECT_LT(after.live_allocations, 4u);
    EXPECT_GT(after.live_bytes, 0u);
    nfd_mesh_destroy(mesh);
    nfd_asset_destroy(asset);
    nfd_context_destroy(vk);
}

TEST_F(Api, AssetArgumentsAndInfo) {
    nfd_asset* a = reinterpret_cast<nfd_asset*>(0x1);
    const uint8_t byte = 0;
    EXPECT_EQ(nfd_asset_create(nullptr, 10, &a), NFD_ERROR_INVALID_ARGUMENT);
    EXPECT_EQ(a, nullptr);
    EXPECT_EQ(nfd_asset_create(&byte, 1, nullptr), NFD_ERROR_INVALID_ARGUMENT);
    EXPECT_EQ(nfd_asset_create(&byte, 0, &a), NFD_ERROR_TRUNCATED);
    EXPECT_EQ(nfd_asset_create(&byte, 1, &a), NFD_ERROR_TRUNCATED);
    nfd_asset_destroy(nullptr);

    nfd_asset_info info;
    EXPECT_EQ(nfd_asset_get_info(nullptr, &info), NFD_ERROR_INVALID_ARGUMENT);
    EXPECT_EQ(nfd_asset_get_info(asset, nullptr), NFD_ERROR_INVALID_ARGUMENT);
    ASSERT_EQ(nfd_asset_get_info(asset, &info), NFD_SUCCESS);
    EXPECT_EQ(info.format_major, 1u);
    EXPECT_EQ(info.format_minor, 0u);
    EXPECT_EQ(info.field_type, NFD_FIELD_SDF);
    EXPECT_EQ(info.scale, 2.0f);
    EXPECT_EQ(info.center[0], 1.0f);
    EXPECT_EQ(info.num_frequencies, 2u);
    EXPECT_EQ(info.num_layers, 3u);
    EXPECT_EQ(info.layer_widths[0], 3u);
    EXPECT_EQ(info.layer_widths[2], 1u);
    EXPECT_EQ(info.bits, 16u);
    EXPECT_EQ(info.parameter_count, uint32_t(closed_blob().parameter_count()));
    EXPECT_EQ(info.has_colour, 0);
    EXPECT_EQ(info.file_size, uint32_t(geom_file(closed_blob(2.0f, center)).size()));
}

TEST_F(Api, EvaluateTakesOriginalFrameAndReturnsUnitDistances) {
    EXPECT_EQ(nfd_asset_evaluate(nullptr, asset, nullptr, 0, nullptr), NFD_ERROR_INVALID_ARGUMENT);
    EXPECT_EQ(nfd_asset_evaluate(ctx, nullptr, nullptr, 0, nullptr), NFD_ERROR_INVALID_ARGUMENT);
    EXPECT_EQ(nfd_asset_evaluate(ctx, asset, nullptr, 0, nullptr), NFD_SUCCESS);
    float v = 0;
    EXPECT_EQ(nfd_asset_evaluate(ctx, asset, nullptr, 1, &v), NFD_ERROR_INVALID_ARGUMENT);
    const float p[3] = {0, 0, 0};
    EXPECT_EQ(nfd_asset_evaluate(ctx, asset, p, 1, nullptr), NFD_ERROR_INVALID_ARGUMENT);

    // The centre of the frame is the blob's centre (inside); u = 0.6 along x is on its surface.
    const float points[6] = {center[0], center[1], center[2],
                             center[0] + 0.6f * 2.0f, center[1], center[2]};
    float values[2];
    ASSERT_EQ(nfd_asset_evaluate(ctx, asset, points, 2, values), NFD_SUCCESS);
    const float unit[6] = {0, 0, 0, 0.6f, 0, 0};
    const Geometry g = parse_or_throw(geom_file(closed_blob()));
    EXPECT_NEAR(values[0], evaluate_f64(g.network, unit), 1e-5);
    EXPECT_LT(values[0], -0.1f);
    EXPECT_NEAR(values[1], 0.0f, 1e-3);
}

TEST_F(Api, EvaluateGradientArguments) {
    float v = 0, g[3] = {0, 0, 0};
    const float p[3] = {0, 0, 0};
    const nfd_result bad = NFD_ERROR_INVALID_ARGUMENT;
    EXPECT_EQ(nfd_asset_evaluate_gradient(nullptr, asset, p, 1, &v, g), bad);
    EXPECT_EQ(nfd_asset_evaluate_gradient(ctx, nullptr, p, 1, &v, g), bad);
    EXPECT_EQ(nfd_asset_evaluate_gradient(ctx, asset, nullptr, 0, nullptr, nullptr), NFD_SUCCESS);
    EXPECT_EQ(nfd_asset_evaluate_gradient(ctx, asset, nullptr, 1, &v, g), bad);
    EXPECT_EQ(nfd_asset_evaluate_gradient(ctx, asset, p, 1, nullptr, g), bad);
    EXPECT_EQ(nfd_asset_evaluate_gradient(ctx, asset, p, 1, &v, nullptr), bad);
}

// On the golden vectors (SDF and UDF), original-frame points, on the CPU context and (where there
// is one) a Vulkan one: the values are nfd_asset_evaluate's and the gradients the internal
// evaluator's at the same unit-frame points (bit for bit on the CPU, as test_gpu.cpp bounds the
// GPU's); the blob's closed-form gradient checks the frame: the API's gradient is dimensionless.
TEST_F(Api, EvaluateGradientOnGoldenVectors) {
    std::vector<nfd_context*> contexts = {ctx};
    nfd_context* vk = nullptr;
    nfd_context_options o = {};
    o.device = NFD_DEVICE_VULKAN;
    if (nfd_context_create(&o, &vk) == NFD_SUCCESS) contexts.push_back(vk);
    std::mt19937 rng(3);
    std::uniform_real_distribution<float> uniform(-1.0f, 1.0f);
    for (const std::string& name : golden_names()) {
        SCOPED_TRACE(name);
        const Bytes bytes = read_bytes(golden_path(name, ".nfc"));
        nfd_asset* a = nullptr;
        ASSERT_EQ(nfd_asset_create(bytes.data(), bytes.size(), &a), NFD_SUCCESS);
        const Geometry g = parse_or_throw(bytes);
        const size_t n = 3000;
        std::vector<float> points(3 * n), unit(3 * n);
        for (size_t i = 0; i < 3 * n; ++i) {
            // Relative to the asset's offset, as the API takes positions (geo-referenced files)
            const float center = g.emit_center(int(i % 3));
            points[i] = uniform(rng) * g.scale + center;
            unit[i] = (points[i] - center) / g.scale;  // as the API maps them
        }
        std::vector<float> want(n), want_gradients(3 * n);
        evaluate_gradient_cpu(g.network, unit.data(), n, want.data(), want_gradients.data());
        for (nfd_context* c : contexts) {
            SCOPED_TRACE(nfd_context_device_name(c));
            const bool cpu = nfd_context_device_kind(c) == NFD_DEVICE_CPU;
            std::vector<float> plain(n), values(n), gradients(3 * n);
            ASSERT_EQ(nfd_asset_evaluate(c, a, points.data(), n, plain.data()), NFD_SUCCESS);
            ASSERT_EQ(nfd_asset_evaluate_gradient(c, a, points.data(), n, values.data(),
                                                  gradients.data()),
                      NFD_SUCCESS);
            EXPECT_EQ(values, plain);
            if (cpu) {
                EXPECT_EQ(gradients, want_gradients);
                continue;
            }
            for (size_t i = 0; i < 3 * n; ++i)
                ASSERT_NEAR(gradients[i], want_gradients[i], 1e-4 * (1 + std::fabs(want_gradients[i])))
                    << i;
        }
        nfd_asset_destroy(a);
    }
    nfd_context_destroy(vk);
}

// The closed blob, f(u) = sin(30 * -0.01 * (sum cos(2 u_j) - T)) / 0.6 (test_network.cpp): its
// gradient in the unit frame, whatever the asset's scale (2 here), since the distance is in the
// unit frame too.
TEST_F(Api, EvaluateGradientIsDimensionless) {
    const float points[6] = {center[0] + 0.6f * 2.0f, center[1], center[2],
                             center[0] + 0.3f * 2.0f, center[1] - 0.2f * 2.0f, center[2]};
    const double unit[2][3] = {{0.6, 0, 0}, {0.3, -0.2, 0}};
    float values[2], gradients[6];
    ASSERT_EQ(nfd_asset_evaluate_gradient(ctx, asset, points, 2, values, gradients), NFD_SUCCESS);
    const double T = std::cos(1.2) + 2.0;
    for (int i = 0; i < 2; ++i) {
        double sum = 0;
        for (int j = 0; j < 3; ++j) sum += std::cos(2.0 * unit[i][j]);
        const double outer = std::cos(30.0 * -0.01 * (sum - T)) * 30.0 * -0.01 / 0.6;
        for (int j = 0; j < 3; ++j)
            EXPECT_NEAR(gradients[3 * i + j], outer * -2.0 * std::sin(2.0 * unit[i][j]), 2e-3)
                << i << " " << j;  // the hand-made weights are quantized (as the value test)
    }
}

TEST_F(Api, MeshOptionsDefaultsAndLimits) {
    EXPECT_EQ(nfd_mesh_extract(ctx, asset, nullptr, nullptr), NFD_ERROR_INVALID_ARGUMENT);
    nfd_mesh* m = reinterpret_cast<nfd_mesh*>(0x1);
    EXPECT_EQ(nfd_mesh_extract(nullptr, asset, nullptr, &m), NFD_ERROR_INVALID_ARGUMENT);
    EXPECT_EQ(m, nullptr);
    EXPECT_EQ(nfd_mesh_extract(ctx, nullptr, nullptr, &m), NFD_ERROR_INVALID_ARGUMENT);
    nfd_mesh_options mo = {};
    mo.resolution = NFD_MIN_RESOLUTION - 1;
    EXPECT_EQ(nfd_mesh_extract(ctx, asset, &mo, &m), NFD_ERROR_LIMIT_EXCEEDED);
    mo.resolution = NFD_MAX_RESOLUTION + 1;
    EXPECT_EQ(nfd_mesh_extract(ctx, asset, &mo, &m), NFD_ERROR_LIMIT_EXCEEDED);

    // NULL options, zeroed options and the documented default give the same mesh.
    nfd_mesh *a = nullptr, *b = nullptr, *c = nullptr;
    const nfd_mesh_options zero = {};
    nfd_mesh_options explicit_default = {};
    explicit_default.resolution = NFD_DEFAULT_RESOLUTION;
    ASSERT_EQ(nfd_mesh_extract(ctx, asset, nullptr, &a), NFD_SUCCESS);
    ASSERT_EQ(nfd_mesh_extract(ctx, asset, &zero, &b), NFD_SUCCESS);
    ASSERT_EQ(nfd_mesh_extract(ctx, asset, &explicit_default, &c), NFD_SUCCESS);
    nfd_mesh_data da, db, dc;
    ASSERT_EQ(nfd_mesh_get_data(a, &da), NFD_SUCCESS);
    ASSERT_EQ(nfd_mesh_get_data(b, &db), NFD_SUCCESS);
    ASSERT_EQ(nfd_mesh_get_data(c, &dc), NFD_SUCCESS);
    EXPECT_GT(da.triangle_count, 10000u);
    EXPECT_EQ(da.triangle_count, db.triangle_count);
    EXPECT_EQ(da.triangle_count, dc.triangle_count);
    nfd_decode_stats stats;
    ASSERT_EQ(nfd_mesh_get_stats(a, &stats), NFD_SUCCESS);
    EXPECT_GT(stats.points_evaluated, 0u);
    EXPECT_GT(stats.active_cells, 0u);
    EXPECT_GE(stats.seconds_field, 0.0);
    nfd_mesh_destroy(a);
    nfd_mesh_destroy(b);
    nfd_mesh_destroy(c);
    nfd_mesh_destroy(nullptr);
    EXPECT_EQ(nfd_mesh_get_data(nullptr, &da), NFD_ERROR_INVALID_ARGUMENT);
    EXPECT_EQ(nfd_mesh_get_stats(nullptr, &stats), NFD_ERROR_INVALID_ARGUMENT);
}

// nfd_mesh_options.sample_band (0.11) on a learned SDF, CPU path: the band finds the mesh that
// following the surface finds (the same triangles here) from more than twice the evaluations, the
// same way through the one-shot, the memory-limited and the progressive paths.
TEST(ApiSampleBand, BandAndSurfaceFollowingGiveTheSameMesh) {
    nfd_context_options co = {};
    co.device = NFD_DEVICE_CPU;
    nfd_context* ctx = nullptr;
    ASSERT_EQ(nfd_context_create(&co, &ctx), NFD_SUCCESS);
    const Bytes bytes = read_bytes(golden_path("bunny_sdf_w16", ".nfc"));
    nfd_asset* asset = nullptr;
    ASSERT_EQ(nfd_asset_create(bytes.data(), bytes.size(), &asset), NFD_SUCCESS);
    auto decode = [&](int band, uint64_t limit, nfd_decode_stats* stats) {
        nfd_mesh_options mo = {};
        mo.struct_size = sizeof mo;
        mo.resolution = 128;
        mo.sample_band = band;
        mo.max_host_bytes = limit;
        nfd_mesh* mesh = nullptr;
        EXPECT_EQ(nfd_mesh_extract(ctx, asset, &mo, &mesh), NFD_SUCCESS);
        nfd_mesh_get_stats(mesh, stats);
        nfd_mesh_data d;
        nfd_mesh_get_data(mesh, &d);
        const size_t triangles = d.triangle_count;
        nfd_mesh_destroy(mesh);
        return triangles;
    };
    nfd_decode_stats follow, band, band_limited;
    const size_t triangles = decode(0, 0, &follow);
    EXPECT_EQ(decode(1, 0, &band), triangles);
    EXPECT_EQ(decode(1, uint64_t(1) << 33, &band_limited), triangles);
    EXPECT_EQ(band.active_cells, follow.active_cells);
    EXPECT_GT(band.points_evaluated, 2 * follow.points_evaluated);
    EXPECT_EQ(band_limited.points_evaluated, band.points_evaluated);
    nfd_decode_stats hostile;  // any non-zero value means yes
    for (int value : {-1, INT32_MIN, INT32_MAX}) {
        EXPECT_EQ(decode(value, 0, &hostile), triangles) << value;
        EXPECT_EQ(hostile.points_evaluated, band.points_evaluated) << value;
    }

    nfd_extraction_options eo = {};
    eo.struct_size = sizeof eo;
    eo.resolution = 128;
    eo.sample_band = 1;
    nfd_extraction* ex = nullptr;
    ASSERT_EQ(nfd_extraction_create(ctx, asset, &eo, &ex), NFD_SUCCESS);
    uint64_t points = 0;
    for (bool done = false; !done;) {
        nfd_extraction_level info{};
        info.struct_size = sizeof info;
        nfd_mesh* mesh = nullptr;
        ASSERT_EQ(nfd_extraction_step(ex, &mesh, &info), NFD_SUCCESS);
        points += info.points_evaluated;
        done = info.done != 0;
        nfd_mesh_destroy(mesh);
    }
    EXPECT_EQ(points, band.points_evaluated);
    nfd_extraction_destroy(ex);
    nfd_asset_destroy(asset);
    nfd_context_destroy(ctx);
}

// A UDF golden vector meshes through the API and samples points like an SDF.
TEST_F(Api, UdfIsMeshedAndSampled) {
    const Bytes b = read_bytes(golden_path("tshirt_udf_w16", ".nfc"));
    nfd_asset* udf = nullptr;
    ASSERT_EQ(nfd_asset_create(b.data(), b.size(), &udf), NFD_SUCCESS);
    nfd_mesh_options mo = {};
    mo.resolution = 64;
    nfd_mesh* m = nullptr;
    ASSERT_EQ(nfd_mesh_extract(ctx, udf, &mo, &m), NFD_SUCCESS);
    nfd_mesh_data d;
    ASSERT_EQ(nfd_mesh_get_data(m, &d), NFD_SUCCESS);
    EXPECT_GT(d.triangle_count, 1000u);
    std::vector<float> p1(300), p2(300);
    EXPECT_EQ(nfd_mesh_sample_points(m, 100, 5, p1.data(), nullptr), NFD_SUCCESS);
    EXPECT_EQ(nfd_mesh_sample_points(m, 100, 5, p2.data(), nullptr), NFD_SUCCESS);
    EXPECT_EQ(p1, p2);  // deterministic for a seed
    float v;
    const float p[3] = {0, 0, 0};
    EXPECT_EQ(nfd_asset_evaluate(ctx, udf, p, 1, &v), NFD_SUCCESS);
    EXPECT_GE(v, 0.0f);
    nfd_mesh_destroy(m);
    nfd_asset_destroy(udf);
}

TEST_F(Api, SamplePoints) {
    extract(48);
    std::vector<float> p1(3000), p2(3000), p3(3000), n1(3000);
    EXPECT_EQ(nfd_mesh_sample_points(nullptr, 1, 0, p1.data(), nullptr), NFD_ERROR_INVALID_ARGUMENT);
    EXPECT_EQ(nfd_mesh_sample_points(mesh, 1, 0, nullptr, nullptr), NFD_ERROR_INVALID_ARGUMENT);
    EXPECT_EQ(nfd_mesh_sample_points(mesh, 0, 0, nullptr, nullptr), NFD_SUCCESS);
    ASSERT_EQ(nfd_mesh_sample_points(mesh, 1000, 7, p1.data(), n1.data()), NFD_SUCCESS);
    ASSERT_EQ(nfd_mesh_sample_points(mesh, 1000, 7, p2.data(), nullptr), NFD_SUCCESS);
    ASSERT_EQ(nfd_mesh_sample_points(mesh, 1000, 8, p3.data(), nullptr), NFD_SUCCESS);
    EXPECT_EQ(p1, p2);  // deterministic for a seed
    EXPECT_NE(p1, p3);
    std::vector<float> values(1000);
    ASSERT_EQ(nfd_asset_evaluate(ctx, asset, p1.data(), 1000, values.data()), NFD_SUCCESS);
    for (size_t i = 0; i < 1000; ++i) {
        ASSERT_LT(std::fabs(values[i]), 0.01f) << i;  // on the surface (flat facets: O(h^2) off)
        const float* n = &n1[3 * i];
        ASSERT_NEAR(n[0] * n[0] + n[1] * n[1] + n[2] * n[2], 1.0f, 1e-4f);
        // Face normals point outward: away from the frame centre for this star-shaped blob.
        const float d = n[0] * (p1[3 * i] - center[0]) + n[1] * (p1[3 * i + 1] - center[1]) +
                        n[2] * (p1[3 * i + 2] - center[2]);
        ASSERT_GT(d, 0.0f) << i;
    }
}

TEST_F(Api, EmptyMeshIsSuccessButCannotBeSampled) {
    GeomSpec positive = closed_blob();
    positive.levels.back() = 20000;  // f > 0 everywhere
    const Bytes b = geom_file(positive);
    nfd_asset* empty_asset = nullptr;
    ASSERT_EQ(nfd_asset_create(b.data(), b.size(), &empty_asset), NFD_SUCCESS);
    nfd_mesh_options mo = {};
    mo.resolution = 16;
    nfd_mesh* empty = nullptr;
    ASSERT_EQ(nfd_mesh_extract(ctx, empty_asset, &mo, &empty), NFD_SUCCESS);
    nfd_mesh_data d;
    ASSERT_EQ(nfd_mesh_get_data(empty, &d), NFD_SUCCESS);
    EXPECT_EQ(d.triangle_count, 0u);
    float p[3];
    EXPECT_EQ(nfd_mesh_sample_points(empty, 1, 0, p, nullptr), NFD_ERROR_INVALID_ARGUMENT);
    const std::string glb = temp_path("empty.glb"), ply = temp_path("empty.ply");
    EXPECT_EQ(nfd_mesh_write_glb(empty, glb.c_str()), NFD_SUCCESS);
    EXPECT_EQ(nfd_mesh_write_ply(empty, ply.c_str()), NFD_SUCCESS);
    EXPECT_EQ(read_ply(ply).triangle_count(), 0u);
    std::remove(glb.c_str());
    std::remove(ply.c_str());
    nfd_mesh_destroy(empty);
    nfd_asset_destroy(empty_asset);
}

uint32_t le32(const Bytes& b, size_t at) {
    return uint32_t(b[at]) | uint32_t(b[at + 1]) << 8 | uint32_t(b[at + 2]) << 16 |
           uint32_t(b[at + 3]) << 24;
}

TEST_F(Api, WritesValidGlb) {
    extract(32);
    nfd_mesh_data d;
    ASSERT_EQ(nfd_mesh_get_data(mesh, &d), NFD_SUCCESS);
    EXPECT_EQ(nfd_mesh_write_glb(nullptr, "x.glb"), NFD_ERROR_INVALID_ARGUMENT);
    EXPECT_EQ(nfd_mesh_write_glb(mesh, nullptr), NFD_ERROR_INVALID_ARGUMENT);
    EXPECT_EQ(nfd_mesh_write_glb(mesh, "/nonexistent-dir/x.glb"), NFD_ERROR_IO);
    EXPECT_EQ(nfd_mesh_write_glb(mesh, "/dev/full"), NFD_ERROR_IO);  // opens, every write fails

    const std::string path = temp_path("mesh.glb");
    ASSERT_EQ(nfd_mesh_write_glb(mesh, path.c_str()), NFD_SUCCESS);
    const Bytes glb = read_bytes(path);
    std::remove(path.c_str());
    // GLB container (glTF 2.0, section 4.4): header, JSON chunk, BIN chunk, 4-byte aligned.
    ASSERT_GE(glb.size(), 28u);
    EXPECT_EQ(le32(glb, 0), 0x46546C67u);  // "glTF"
    EXPECT_EQ(le32(glb, 4), 2u);
    EXPECT_EQ(le32(glb, 8), glb.size());
    const uint32_t json_length = le32(glb, 12);
    EXPECT_EQ(le32(glb, 16), 0x4E4F534Au);  // "JSON"
    EXPECT_EQ(json_length % 4, 0u);
    const size_t bin_at = 20 + json_length;
    ASSERT_LE(bin_at + 8, glb.size());
    EXPECT_EQ(le32(glb, bin_at + 4), 0x004E4942u);  // "BIN\0"
    const uint32_t bin_length = le32(glb, bin_at);
    EXPECT_EQ(bin_at + 8 + bin_length, glb.size());

    const auto j = nlohmann::json::parse(glb.begin() + 20, glb.begin() + 20 + json_length);
    EXPECT_EQ(j["asset"]["version"], "2.0");
    ASSERT_EQ(j["meshes"].size(), 1u);
    ASSERT_EQ(j["nodes"].size(), 1u);
    ASSERT_EQ(j["scenes"].size(), 1u);
    const auto& prim = j["meshes"][0]["primitives"][0];
    const auto& pos = j["accessors"][prim["attributes"]["POSITION"].get<int>()];
    const auto& nrm = j["accessors"][prim["attributes"]["NORMAL"].get<int>()];
    const auto& idx = j["accessors"][prim["indices"].get<int>()];
    EXPECT_EQ(pos["count"], d.vertex_count);
    EXPECT_EQ(nrm["count"], d.vertex_count);
    EXPECT_EQ(idx["count"], 3 * d.triangle_count);
    EXPECT_EQ(pos["componentType"], 5126);
    EXPECT_EQ(idx["componentType"], 5125);  // UNSIGNED_INT
    EXPECT_EQ(pos["type"], "VEC3");
    for (int a = 0; a < 3; ++a) {
        float lo = INFINITY, hi = -INFINITY;
        for (size_t i = 0; i < d.vertex_count; ++i) {
            lo = std::min(lo, d.positions[3 * i + a]);
            hi = std::max(hi, d.positions[3 * i + a]);
        }
        EXPECT_EQ(pos["min"][a].get<double>(), double(lo));
        EXPECT_EQ(pos["max"][a].get<double>(), double(hi));
    }
    // The binary chunk holds exactly the mesh data where the views say.
    const auto& view = j["bufferViews"][idx["bufferView"].get<int>()];
    const size_t at = bin_at + 8 + view.value("byteOffset", 0u) + idx.value("byteOffset", 0u);
    for (size_t k = 0; k < 3 * d.triangle_count; ++k) ASSERT_EQ(le32(glb, at + 4 * k), d.indices[k]);
}

// The bytes tinygltf reads through an accessor, as 4-byte words.
std::vector<uint32_t> accessor_words(const tinygltf::Model& m, int index) {
    const tinygltf::Accessor& a = m.accessors[size_t(index)];
    const tinygltf::BufferView& v = m.bufferViews[size_t(a.bufferView)];
    const size_t words = a.count * size_t(tinygltf::GetNumComponentsInType(uint32_t(a.type)));
    std::vector<uint32_t> out(words);
    std::memcpy(out.data(), m.buffers[size_t(v.buffer)].data.data() + v.byteOffset + a.byteOffset,
                4 * words);
    return out;
}

template <class Vector>
std::vector<uint32_t> words_of(const Vector& values) {
    std::vector<uint32_t> out(values.size());
    std::memcpy(out.data(), values.data(), 4 * values.size());
    return out;
}

// Every part of a .glb as tinygltf reads it: the arrays where the accessors say, colours, the
// geo-referenced offset as the node's translation, min/max; an empty mesh is an empty scene.
TEST_F(Api, GlbLoadsInTinyGltf) {
    extract(48);
    MeshData mesh_data;
    {
        nfd_mesh_data d;
        ASSERT_EQ(nfd_mesh_get_data(mesh, &d), NFD_SUCCESS);
        mesh_data.positions.assign(d.positions, d.positions + 3 * d.vertex_count);
        mesh_data.normals.assign(d.normals, d.normals + 3 * d.vertex_count);
        mesh_data.indices.assign(d.indices, d.indices + 3 * d.triangle_count);
    }
    const std::string path = temp_path("tinygltf.glb");
    for (bool decorated : {false, true}) {
        if (decorated) {  // colours and a far frame
            for (size_t i = 0; i < mesh_data.positions.size(); ++i)
                mesh_data.colours.push_back(float(i % 7) / 6.0f);
            mesh_data.offset = {412345.25, 5612345.5, -31.125};
        }
        ASSERT_EQ(write_glb(mesh_data, path.c_str()), NFD_SUCCESS);
        tinygltf::TinyGLTF loader;
        tinygltf::Model m;
        std::string err, warn;
        ASSERT_TRUE(loader.LoadBinaryFromFile(&m, &err, &warn, path)) << err;
        EXPECT_TRUE(err.empty() && warn.empty()) << err << warn;
        ASSERT_EQ(m.meshes.size(), 1u);
        ASSERT_EQ(m.nodes.size(), 1u);
        const tinygltf::Primitive& p = m.meshes[0].primitives.at(0);
        EXPECT_EQ(p.mode, TINYGLTF_MODE_TRIANGLES);
        EXPECT_EQ(accessor_words(m, p.attributes.at("POSITION")), words_of(mesh_data.positions));
        EXPECT_EQ(accessor_words(m, p.attributes.at("NORMAL")), words_of(mesh_data.normals));
        EXPECT_EQ(accessor_words(m, p.indices), words_of(mesh_data.indices));
        EXPECT_EQ(m.accessors[size_t(p.indices)].componentType, TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT);
        const tinygltf::Accessor& position = m.accessors[size_t(p.attributes.at("POSITION"))];
        for (int a = 0; a < 3; ++a) {
            float lo = INFINITY, hi = -INFINITY;
            for (size_t i = a; i < mesh_data.positions.size(); i += 3) {
                lo = std::min(lo, mesh_data.positions[i]);
                hi = std::max(hi, mesh_data.positions[i]);
            }
            EXPECT_EQ(position.minValues.at(size_t(a)), double(lo));
            EXPECT_EQ(position.maxValues.at(size_t(a)), double(hi));
        }
        if (decorated) {
            EXPECT_EQ(accessor_words(m, p.attributes.at("COLOR_0")), words_of(mesh_data.colours));
            EXPECT_EQ(m.nodes[0].translation,
                      std::vector<double>(mesh_data.offset.begin(), mesh_data.offset.end()));
        } else {
            EXPECT_EQ(p.attributes.count("COLOR_0"), 0u);
            EXPECT_TRUE(m.nodes[0].translation.empty());
        }
    }
    ASSERT_EQ(write_glb(MeshData{}, path.c_str()), NFD_SUCCESS);
    tinygltf::TinyGLTF loader;
    tinygltf::Model m;
    std::string err, warn;
    ASSERT_TRUE(loader.LoadBinaryFromFile(&m, &err, &warn, path)) << err;
    EXPECT_TRUE(m.meshes.empty() && m.nodes.empty() && m.buffers.empty());
    ASSERT_EQ(m.scenes.size(), 1u);
    EXPECT_TRUE(m.scenes[0].nodes.empty());
    std::remove(path.c_str());
}

TEST_F(Api, WritesPly) {
    extract(24);
    nfd_mesh_data d;
    ASSERT_EQ(nfd_mesh_get_data(mesh, &d), NFD_SUCCESS);
    EXPECT_EQ(nfd_mesh_write_ply(mesh, "/nonexistent-dir/x.ply"), NFD_ERROR_IO);
    EXPECT_EQ(nfd_mesh_write_ply(mesh, "/dev/full"), NFD_ERROR_IO);  // opens, every write fails
    const std::string path = temp_path("mesh.ply");
    ASSERT_EQ(nfd_mesh_write_ply(mesh, path.c_str()), NFD_SUCCESS);
    const MeshData back = read_ply(path);
    std::remove(path.c_str());
    ASSERT_EQ(back.vertex_count(), d.vertex_count);
    EXPECT_TRUE(std::equal(back.positions.begin(), back.positions.end(), d.positions));
    EXPECT_TRUE(std::equal(back.indices.begin(), back.indices.end(), d.indices));

    std::vector<float> pts(300), nrm(300);
    ASSERT_EQ(nfd_mesh_sample_points(mesh, 100, 1, pts.data(), nrm.data()), NFD_SUCCESS);
    EXPECT_EQ(nfd_points_write_ply(nullptr, nullptr, 1, path.c_str()), NFD_ERROR_INVALID_ARGUMENT);
    EXPECT_EQ(nfd_points_write_ply(pts.data(), nullptr, 100, nullptr), NFD_ERROR_INVALID_ARGUMENT);
    for (const float* normals : {static_cast<const float*>(nullptr), static_cast<const float*>(nrm.data())}) {
        ASSERT_EQ(nfd_points_write_ply(pts.data(), normals, 100, path.c_str()), NFD_SUCCESS);
        const MeshData cloud = read_ply(path);
        EXPECT_EQ(std_vector(cloud.positions), pts);
        EXPECT_EQ(cloud.triangle_count(), 0u);
    }
    std::remove(path.c_str());
}

}  // namespace
}  // namespace nfd::test
