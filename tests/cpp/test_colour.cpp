// Colour (format 1.1; nfdecode.h "Colour"): the colour network on the CPU against f64 and against
// the numpy reference's golden colours; colour on every output (meshes, progressive levels, queue
// jobs, points, grids) and in the writers (PLY, glTF); geometry only on request; files without
// colour unchanged. The Vulkan twins are in test_colour_gpu.cpp, VDB colour in test_vdb.cpp.
#include <gtest/gtest.h>
#include <nfdecode/nfdecode.h>

#include <cstdio>
#include <memory>
#include <nlohmann/json.hpp>
#include <random>
#include <string>
#include <vector>

#include "colour_util.h"
#include "export.h"
#include "test_util.h"

namespace nfd::test {
namespace {

const float kCentre[3] = {1.5f, -2.0f, 0.25f};

// The closed blob (a surface at |u| ~ 0.6) with a random colour network, and the same geometry
// without colour.
Bytes coloured_blob() { return coloured_file(closed_blob(2.0f, kCentre), random_colour_siren(16, 8, 31)); }
Bytes plain_blob() { return geom_file(closed_blob(2.0f, kCentre)); }

TEST(Colour, CpuMatchesF64Reference) {
    const Network net = parse_colour(coloured_blob());
    std::mt19937 rng(5);
    std::uniform_real_distribution<float> u(-1.0f, 1.0f);
    std::vector<float> points(3 * 1000);
    for (float& x : points) x = u(rng);
    std::vector<float> rgb(points.size());
    evaluate_cpu(net, points.data(), 1000, rgb.data());
    for (size_t i = 0; i < 1000; ++i) {
        const std::vector<double> expected = evaluate_f64_outputs(net, &points[3 * i]);
        ASSERT_EQ(expected.size(), 3u);
        for (int c = 0; c < 3; ++c) {
            ASSERT_NEAR(rgb[3 * i + c], expected[c], 1e-6) << i;
            ASSERT_GE(rgb[3 * i + c], 0.0f);
            ASSERT_LE(rgb[3 * i + c], 1.0f);
        }
    }
}

TEST(Colour, MeshVerticesCarryTheColourField) {
    const ContextPtr ctx = cpu_context();
    const AssetPtr asset = make_asset(coloured_blob()), plain = make_asset(plain_blob());
    nfd_asset_info info{};
    ASSERT_EQ(nfd_asset_get_info(asset.get(), &info), NFD_SUCCESS);
    EXPECT_EQ(info.has_colour, 1);
    EXPECT_EQ(info.format_minor, 1u);

    const MeshPtr mesh = extract(ctx.get(), asset.get(), 64);
    const MeshArrays m = arrays_of(mesh.get());
    ASSERT_GT(m.indices.size(), 0u);
    ASSERT_EQ(m.colours.size(), m.positions.size());
    // The colour at each vertex is the field's there: the same evaluation as the API's.
    EXPECT_EQ(m.colours, colours_at(ctx.get(), asset.get(), m.positions));
    // Colour changes nothing of the geometry.
    EXPECT_TRUE(m.same_geometry(arrays_of(extract(ctx.get(), plain.get(), 64).get())));
    // Geometry only on request.
    EXPECT_TRUE(arrays_of(extract(ctx.get(), asset.get(), 64, /*skip_colour=*/true).get())
                    .colours.empty());
}

TEST(Colour, AFileWithoutColourHasNone) {
    const ContextPtr ctx = cpu_context();
    for (const std::string& name : golden_names()) {
        if (golden_prefix(std::filesystem::path(golden_path(name, ".nfc")).filename()) != "v1_0_")
            continue;
        const AssetPtr asset = make_asset(read_bytes(golden_path(name, ".nfc")));
        nfd_asset_info info{};
        ASSERT_EQ(nfd_asset_get_info(asset.get(), &info), NFD_SUCCESS);
        EXPECT_EQ(info.has_colour, 0) << name;
        EXPECT_EQ(info.format_minor, 0u) << name;
        const MeshPtr mesh = extract(ctx.get(), asset.get(), 32);
        EXPECT_TRUE(arrays_of(mesh.get()).colours.empty()) << name;
        const float point[3] = {0, 0, 0};
        float rgb[3];
        EXPECT_EQ(nfd_asset_evaluate_colour(ctx.get(), asset.get(), point, 1, rgb),
                  NFD_ERROR_NO_COLOUR);
        EXPECT_EQ(nfd_mesh_evaluate_colours(ctx.get(), asset.get(), mesh.get()),
                  NFD_ERROR_NO_COLOUR);
    }
}

TEST(Colour, ArgumentRules) {
    const ContextPtr ctx = cpu_context();
    const AssetPtr asset = make_asset(coloured_blob());
    const float point[3] = {0.1f, 0.2f, 0.3f};
    float rgb[3];
    EXPECT_EQ(nfd_asset_evaluate_colour(nullptr, asset.get(), point, 1, rgb), NFD_ERROR_INVALID_ARGUMENT);
    EXPECT_EQ(nfd_asset_evaluate_colour(ctx.get(), nullptr, point, 1, rgb), NFD_ERROR_INVALID_ARGUMENT);
    EXPECT_EQ(nfd_asset_evaluate_colour(ctx.get(), asset.get(), nullptr, 1, rgb), NFD_ERROR_INVALID_ARGUMENT);
    EXPECT_EQ(nfd_asset_evaluate_colour(ctx.get(), asset.get(), point, 1, nullptr), NFD_ERROR_INVALID_ARGUMENT);
    EXPECT_EQ(nfd_asset_evaluate_colour(ctx.get(), asset.get(), nullptr, 0, nullptr), NFD_SUCCESS);
    const MeshPtr mesh = extract(ctx.get(), asset.get(), 32);
    EXPECT_EQ(nfd_mesh_evaluate_colours(nullptr, asset.get(), mesh.get()), NFD_ERROR_INVALID_ARGUMENT);
    EXPECT_EQ(nfd_mesh_evaluate_colours(ctx.get(), asset.get(), nullptr), NFD_ERROR_INVALID_ARGUMENT);
    const float* colours = nullptr;
    EXPECT_EQ(nfd_points_write_coloured_ply(nullptr, nullptr, rgb, 1, "/tmp/nfd_unused.ply"),
              NFD_ERROR_INVALID_ARGUMENT);
    EXPECT_EQ(nfd_points_write_coloured_ply(point, nullptr, rgb, 1, nullptr),
              NFD_ERROR_INVALID_ARGUMENT);
    EXPECT_EQ(nfd_points_write_coloured_ply(point, nullptr, rgb, 1, "/nonexistent-dir/x.ply"),
              NFD_ERROR_IO);
    EXPECT_EQ(nfd_mesh_get_colours(nullptr, &colours), NFD_ERROR_INVALID_ARGUMENT);
    EXPECT_EQ(nfd_mesh_get_colours(mesh.get(), nullptr), NFD_ERROR_INVALID_ARGUMENT);
    EXPECT_EQ(nfd_grid_get_colours(nullptr, &colours), NFD_ERROR_INVALID_ARGUMENT);
}

// Every delivered level is coloured, the final one as the one-shot mesh; skip_colour holds.
TEST(Colour, ProgressiveLevelsAndQueueJobsAreColoured) {
    const ContextPtr ctx = cpu_context();
    const AssetPtr asset = make_asset(coloured_blob());
    const MeshArrays one_shot = arrays_of(extract(ctx.get(), asset.get(), 128).get());
    for (int skip : {0, 1}) {
        nfd_extraction_options eo{};
        eo.struct_size = sizeof eo;
        eo.resolution = 128;
        eo.skip_colour = skip;
        nfd_extraction* e = nullptr;
        ASSERT_EQ(nfd_extraction_create(ctx.get(), asset.get(), &eo, &e), NFD_SUCCESS);
        const std::unique_ptr<nfd_extraction, void (*)(nfd_extraction*)> extraction(
            e, &nfd_extraction_destroy);
        nfd_extraction_level level{};
        MeshArrays last;
        do {
            level.struct_size = sizeof level;
            nfd_mesh* m = nullptr;
            ASSERT_EQ(nfd_extraction_step(e, &m, &level), NFD_SUCCESS);
            const MeshPtr mesh(m);
            last = arrays_of(mesh.get());
            EXPECT_EQ(last.colours.size(), skip ? 0 : last.positions.size()) << level.resolution;
        } while (!level.done);
        EXPECT_TRUE(last.same_geometry(one_shot));
        if (!skip) EXPECT_EQ(last.colours, one_shot.colours);
    }

    nfd_queue* q = nullptr;
    ASSERT_EQ(nfd_queue_create(ctx.get(), nullptr, &q), NFD_SUCCESS);
    const std::unique_ptr<nfd_queue, void (*)(nfd_queue*)> queue(q, &nfd_queue_destroy);
    for (int skip : {0, 1}) {
        nfd_mesh_options mo{};
        mo.struct_size = sizeof mo;
        mo.resolution = 128;
        mo.skip_colour = skip;
        nfd_job* j = nullptr;
        ASSERT_EQ(nfd_queue_submit(q, asset.get(), &mo, nullptr, &j), NFD_SUCCESS);
        const std::unique_ptr<nfd_job, void (*)(nfd_job*)> job(j, &nfd_job_destroy);
        ASSERT_EQ(nfd_job_wait(j, UINT64_MAX), NFD_JOB_DONE);
        nfd_mesh* m = nullptr;
        ASSERT_EQ(nfd_job_take_mesh(j, &m), NFD_SUCCESS);
        const MeshArrays delivered = arrays_of(MeshPtr(m).get());
        EXPECT_TRUE(delivered.same_geometry(one_shot));
        EXPECT_EQ(delivered.colours, skip ? std::vector<float>{} : one_shot.colours);
    }
}

std::string temp_path(const std::string& name) {
    return (std::filesystem::temp_directory_path() /
            ("nfd_colour_" + std::to_string(::getpid()) + "_" + name))
        .string();
}

// PLY: uchar red, green, blue after the normals, rounded as FORMAT.md says; points likewise.
TEST(Colour, PlyCarriesEightBitColour) {
    const ContextPtr ctx = cpu_context();
    const AssetPtr asset = make_asset(coloured_blob());
    const MeshPtr mesh = extract(ctx.get(), asset.get(), 48);
    const MeshArrays m = arrays_of(mesh.get());
    const std::string path = temp_path("mesh.ply");
    ASSERT_EQ(nfd_mesh_write_ply(mesh.get(), path.c_str()), NFD_SUCCESS);
    const MeshData read = read_ply(path);
    std::remove(path.c_str());
    ASSERT_EQ(read.colours.size(), m.colours.size());
    for (size_t i = 0; i < m.colours.size(); ++i)
        ASSERT_EQ(read.colours[i], float(colour_byte(m.colours[i])) / 255.0f) << i;
    EXPECT_EQ(std_vector(read.indices), m.indices);

    std::vector<float> points(3 * 500), rgb(3 * 500);
    ASSERT_EQ(nfd_mesh_sample_points(mesh.get(), 500, 3, points.data(), nullptr), NFD_SUCCESS);
    ASSERT_EQ(nfd_asset_evaluate_colour(ctx.get(), asset.get(), points.data(), 500, rgb.data()),
              NFD_SUCCESS);
    const std::string cloud = temp_path("points.ply");
    ASSERT_EQ(nfd_points_write_coloured_ply(points.data(), nullptr, rgb.data(), 500, cloud.c_str()),
              NFD_SUCCESS);
    const MeshData read_cloud = read_ply(cloud);
    std::remove(cloud.c_str());
    EXPECT_EQ(std_vector(read_cloud.positions), points);
    ASSERT_EQ(read_cloud.colours.size(), rgb.size());
    for (size_t i = 0; i < rgb.size(); ++i)
        ASSERT_EQ(read_cloud.colours[i], float(colour_byte(rgb[i])) / 255.0f) << i;
}

TEST(Colour, ColourBytesRoundToNearest) {
    EXPECT_EQ(colour_byte(0.0f), 0);
    EXPECT_EQ(colour_byte(1.0f), 255);
    EXPECT_EQ(colour_byte(0.5f), 128);            // 127.5 rounds up
    EXPECT_EQ(colour_byte(127.49f / 255.0f), 127);
    EXPECT_EQ(colour_byte(-0.1f), 0);
    EXPECT_EQ(colour_byte(1.1f), 255);
    EXPECT_EQ(colour_byte(std::nanf("")), 0);
}

// glTF: COLOR_0, float VEC3, one per vertex, holding the colours exactly.
TEST(Colour, GlbCarriesColour0) {
    const ContextPtr ctx = cpu_context();
    const AssetPtr asset = make_asset(coloured_blob());
    const MeshPtr mesh = extract(ctx.get(), asset.get(), 48);
    const MeshArrays m = arrays_of(mesh.get());
    const std::string path = temp_path("mesh.glb");
    ASSERT_EQ(nfd_mesh_write_glb(mesh.get(), path.c_str()), NFD_SUCCESS);
    const Bytes glb = read_bytes(path);
    std::remove(path.c_str());
    auto le32 = [&](size_t at) {
        return uint32_t(glb[at]) | uint32_t(glb[at + 1]) << 8 | uint32_t(glb[at + 2]) << 16 |
               uint32_t(glb[at + 3]) << 24;
    };
    const uint32_t json_length = le32(12);
    const auto j = nlohmann::json::parse(glb.begin() + 20, glb.begin() + 20 + json_length);
    const auto& attributes = j["meshes"][0]["primitives"][0]["attributes"];
    ASSERT_TRUE(attributes.contains("COLOR_0"));
    const auto& accessor = j["accessors"][attributes["COLOR_0"].get<int>()];
    EXPECT_EQ(accessor["count"], m.positions.size() / 3);
    EXPECT_EQ(accessor["type"], "VEC3");
    EXPECT_EQ(accessor["componentType"], 5126);  // FLOAT
    const auto& view = j["bufferViews"][accessor["bufferView"].get<int>()];
    const size_t bin = 20 + json_length + 8 + view.value("byteOffset", 0) + accessor.value("byteOffset", 0);
    ASSERT_LE(bin + 4 * m.colours.size(), glb.size());
    EXPECT_EQ(std::memcmp(&glb[bin], m.colours.data(), 4 * m.colours.size()), 0);
}

// Hostile colour networks that pass every check (CRC-consistent damage to the colr payload):
// either an error code, or a mesh whose colours are all in [0, 1].
TEST(Colour, DamagedColourNetworksGiveErrorsOrValidColours) {
    const ContextPtr ctx = cpu_context();
    const Bytes geom = chunk("GEOM", geom_payload(closed_blob()));
    const Bytes payload = colour_payload(random_colour_siren(8, 8, 71));
    size_t accepted = 0;
    for (size_t i = 0; i < payload.size(); i += 3) {
        for (uint8_t pattern : {0x01, 0x40, 0xFF}) {
            Bytes damaged = payload;
            damaged[i] ^= pattern;
            const Bytes bytes = file({geom, chunk("colr", damaged)}, {1, 1, 0});
            nfd_asset* a = nullptr;
            if (nfd_asset_create(bytes.data(), bytes.size(), &a) != NFD_SUCCESS) continue;
            const AssetPtr asset(a);
            ++accepted;
            const MeshArrays m = arrays_of(extract(ctx.get(), asset.get(), 24).get());
            ASSERT_EQ(m.colours.size(), m.positions.size()) << i;
            for (float c : m.colours) ASSERT_TRUE(c >= 0.0f && c <= 1.0f) << i << " " << c;
        }
    }
    EXPECT_GT(accepted, 20u);  // the damage reached the evaluator, not only the parser
}

// Golden colour vectors (tests/vectors/v1_1_*: README.md): the C++ colours against the numpy
// reference's, at the query points (f32 vs f64 arithmetic) and at the reference mesh's vertices.
TEST(Colour, GoldenVectorsMatchTheReference) {
    const std::vector<std::string> names = golden_colour_names();
    ASSERT_FALSE(names.empty()) << "no v1_1 colour vectors in " << vectors_dir();
    const ContextPtr ctx = cpu_context();
    for (const std::string& name : names) {
        const AssetPtr asset = make_asset(read_bytes(golden_path(name, ".nfc")));
        const ColourSamples samples = read_colour_samples(golden_path(name, ".colours.txt"));
        std::vector<float> rgb(samples.unit.size());
        evaluate_cpu(parse_colour(read_bytes(golden_path(name, ".nfc"))), samples.unit.data(),
                     samples.unit.size() / 3, rgb.data());
        const double at_points = max_difference(rgb, samples.rgb);
        EXPECT_LE(at_points, 1e-5) << name;

        const MeshData reference = read_ply(golden_path(name, ".mesh64.ply"));
        const MeshArrays m = arrays_of(extract(ctx.get(), asset.get(), 64).get());
        ASSERT_EQ(m.indices, std_vector(reference.indices)) << name;  // test_extract checks the positions
        ASSERT_EQ(reference.colours.size(), m.colours.size()) << name;
        const double at_vertices = max_difference(m.colours, reference.colours);
        EXPECT_LE(at_vertices, 1.0 / 255.0) << name;
        std::printf("%s: C++ CPU colour vs reference: %.3g at 1024 points, %.3g at %zu vertices\n",
                    name.c_str(), at_points, at_vertices, m.colours.size() / 3);
    }
}

}  // namespace
}  // namespace nfd::test
