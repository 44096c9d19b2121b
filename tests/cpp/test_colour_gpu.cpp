// Colour on the Vulkan path (field_eval.comp with three sigmoid outputs) against the CPU twin and
// against the numpy reference's golden colours: the acceptance is 1/255.
#include <gtest/gtest.h>
#include <nfdecode/nfdecode.h>

#include <cstdio>
#include <random>

#include "colour_util.h"
#include "test_util.h"

namespace nfd::test {
namespace {

class ColourGpu : public ::testing::Test {
protected:
    void SetUp() override {
        gpu_ = make_context(NFD_DEVICE_VULKAN);
        skip_without_vulkan(gpu_ ? "" : "no Vulkan device");
        cpu_ = cpu_context();
    }
    ContextPtr gpu_, cpu_;
};

Bytes coloured_blob() {
    const float centre[3] = {-0.5f, 0.75f, 3.0f};
    return coloured_file(closed_blob(1.5f, centre), random_colour_siren(24, 8, 41));
}

TEST_F(ColourGpu, EvaluateMatchesCpu) {
    const AssetPtr asset = make_asset(coloured_blob());
    std::mt19937 rng(9);
    std::uniform_real_distribution<float> u(-2.0f, 2.0f);
    std::vector<float> points(3 * 5000);
    for (float& x : points) x = u(rng);
    std::vector<float> on_gpu(points.size()), on_cpu(points.size());
    ASSERT_EQ(nfd_asset_evaluate_colour(gpu_.get(), asset.get(), points.data(), 5000, on_gpu.data()),
              NFD_SUCCESS);
    ASSERT_EQ(nfd_asset_evaluate_colour(cpu_.get(), asset.get(), points.data(), 5000, on_cpu.data()),
              NFD_SUCCESS);
    EXPECT_LE(max_difference(on_gpu, on_cpu), 1e-5);
}

// The GPU mesh's colours are the field's at its own vertices (the vertices themselves are
// test_gpu.cpp's business).
TEST_F(ColourGpu, MeshColoursAreTheFieldAtTheVertices) {
    const AssetPtr asset = make_asset(coloured_blob());
    const MeshArrays m = arrays_of(extract(gpu_.get(), asset.get(), 96).get());
    ASSERT_GT(m.indices.size(), 0u);
    ASSERT_EQ(m.colours.size(), m.positions.size());
    EXPECT_LE(max_difference(m.colours, colours_at(cpu_.get(), asset.get(), m.positions)), 1e-5);
    EXPECT_TRUE(arrays_of(extract(gpu_.get(), asset.get(), 96, true).get()).colours.empty());
}

// Acceptance: C++ GPU colours equal the numpy reference within 1/255 on the golden colour vectors.
TEST_F(ColourGpu, GoldenVectorsMatchTheReference) {
    const std::vector<std::string> names = golden_colour_names();
    ASSERT_FALSE(names.empty()) << "no v1_1 colour vectors in " << vectors_dir();
    for (const std::string& name : names) {
        const Bytes bytes = read_bytes(golden_path(name, ".nfc"));
        const AssetPtr asset = make_asset(bytes);
        nfd_asset_info info{};
        ASSERT_EQ(nfd_asset_get_info(asset.get(), &info), NFD_SUCCESS);
        // The query points are in the unit frame; the API takes original positions.
        const ColourSamples samples = read_colour_samples(golden_path(name, ".colours.txt"));
        std::vector<float> original(samples.unit.size()), rgb(samples.unit.size());
        for (size_t i = 0; i < original.size(); ++i)
            original[i] = samples.unit[i] * info.scale + info.center[i % 3];
        ASSERT_EQ(nfd_asset_evaluate_colour(gpu_.get(), asset.get(), original.data(),
                                            original.size() / 3, rgb.data()),
                  NFD_SUCCESS);
        const double at_points = max_difference(rgb, samples.rgb);
        EXPECT_LE(at_points, 1.0 / 255.0) << name;

        const MeshData reference = read_ply(golden_path(name, ".mesh64.ply"));
        MeshData decoded;
        const MeshArrays m = arrays_of(extract(gpu_.get(), asset.get(), 64).get());
        decoded.positions.assign(m.positions.begin(), m.positions.end());
        ASSERT_EQ(m.colours.size(), m.positions.size()) << name;
        // GPU vertices come in another order: match them to the reference's (1e-4 of the scale).
        const std::vector<int64_t> match =
            match_vertices(decoded, reference, 0.01f * info.scale, 1e-4f * info.scale);
        double worst = 0;
        for (size_t i = 0; i < match.size(); ++i) {
            ASSERT_GE(match[i], 0) << name << " vertex " << i;
            for (int c = 0; c < 3; ++c)
                worst = std::max(worst, std::fabs(double(m.colours[3 * i + c]) -
                                                  reference.colours[3 * size_t(match[i]) + c]));
        }
        EXPECT_LE(worst, 1.0 / 255.0) << name;
        std::printf("%s: GPU colour vs reference: %.3g at 1024 points, %.3g at %zu vertices\n",
                    name.c_str(), at_points, worst, match.size());
    }
}

}  // namespace
}  // namespace nfd::test
