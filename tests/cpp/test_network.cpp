// The CPU evaluator against an f64 reimplementation (synthetic networks) and against the Python
// reference decoder's values (golden vectors).
//
// Tolerance: |C++ f32 - reference| <= 1e-5 in unit-frame distance, i.e. 0.01% of the truncation
// band d* = 0.1 and far below a cell at resolution 1024 (0.002). The f32 path's actual error on
// these networks is about 5e-8 (printed by the tests); the margin covers trained weights, which are
// larger than at initialisation, and other C libraries' sinf.
#include <gtest/gtest.h>

#include <cstdio>

#include "test_util.h"

namespace nfd::test {
namespace {

constexpr double kTolerance = 1e-5;

std::vector<float> random_points(size_t n, uint32_t seed, float extent = 1.0f) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<float> u(-extent, extent);
    std::vector<float> p(3 * n);
    for (float& v : p) v = u(rng);
    return p;
}

double max_error_vs_f64(const Network& net, const std::vector<float>& points) {
    const size_t n = points.size() / 3;
    std::vector<float> values(n);
    evaluate_cpu(net, points.data(), n, values.data());
    double worst = 0;
    for (size_t i = 0; i < n; ++i)
        worst = std::max(worst, std::fabs(double(values[i]) - evaluate_f64(net, &points[3 * i])));
    return worst;
}

TEST(Network, MatchesF64ReferenceOnRandomSirens) {
    struct Case {
        uint32_t width;
        uint8_t bits, field;
    };
    for (const Case c : {Case{16, 8, 0}, Case{32, 8, 0}, Case{96, 12, 0}, Case{32, 8, 1}}) {
        const Geometry g = parse_or_throw(geom_file(random_siren(c.width, c.bits, c.width, c.field)));
        // Points inside the unit cube and beyond it (the extractor's last cells reach past 1).
        const double err = max_error_vs_f64(g.network, random_points(5000, 42, 1.1f));
        std::printf("width %u, %u bits, field %u: max |f32 - f64| = %.3g\n", c.width, c.bits,
                    c.field, err);
        EXPECT_LE(err, kTolerance);
    }
}

TEST(Network, OutputActivations) {
    Network net = parse_or_throw(geom_file(random_siren(16, 8, 7))).network;
    const std::vector<float> p = random_points(500, 7);
    for (OutputActivation a :
         {OutputActivation::Identity, OutputActivation::Abs, OutputActivation::Sigmoid}) {
        net.output = a;
        EXPECT_LE(max_error_vs_f64(net, p), kTolerance) << int(a);
    }
    // Abs really is applied: some identity outputs are negative, no abs outputs are.
    std::vector<float> id(500), ab(500);
    net.output = OutputActivation::Identity;
    evaluate_cpu(net, p.data(), 500, id.data());
    net.output = OutputActivation::Abs;
    evaluate_cpu(net, p.data(), 500, ab.data());
    EXPECT_TRUE(std::any_of(id.begin(), id.end(), [](float v) { return v < 0; }));
    for (size_t i = 0; i < 500; ++i) ASSERT_EQ(ab[i], std::fabs(id[i]));
}

TEST(Network, IndependentOfThreadCountAndBlocking) {
    const Network net = parse_or_throw(geom_file(random_siren(32, 8, 9))).network;
    const size_t n = 20011;  // not a multiple of the block size or of the thread split
    const std::vector<float> p = random_points(n, 9);
    std::vector<float> one(n), many(n), single(1);
    evaluate_cpu(net, p.data(), n, one.data(), 1);
    evaluate_cpu(net, p.data(), n, many.data(), 3);
    for (size_t i = 0; i < n; ++i) ASSERT_EQ(one[i], many[i]) << i;
    evaluate_cpu(net, &p[3 * 12345], 1, single.data());
    EXPECT_EQ(single[0], one[12345]);
    evaluate_cpu(net, p.data(), 0, nullptr);  // nothing to do is fine
}

// The closed blob's field is known in closed form: check the evaluator on it too.
TEST(Network, ClosedBlobMatchesItsFormula) {
    const Network net = parse_or_throw(geom_file(closed_blob())).network;
    const std::vector<float> p = random_points(2000, 11);
    std::vector<float> v(2000);
    evaluate_cpu(net, p.data(), 2000, v.data());
    const double T = std::cos(1.2) + 2.0;
    for (size_t i = 0; i < 2000; ++i) {
        double sum = 0;
        for (int j = 0; j < 3; ++j) sum += std::cos(2.0 * p[3 * i + j]);
        const double expected = std::sin(30.0 * -0.01 * (sum - T)) / 0.6;
        ASSERT_NEAR(v[i], expected, 1e-3) << i;  // quantization of the hand-made weights
    }
}

// Golden vectors: tests/vectors/v1_0_<name>.values.txt holds lines "x y z value" (unit frame)
// written by the Python reference decoder (f64) for v1_0_<name>.nfc.
TEST(Network, MatchesPythonReferenceValues) {
    const std::vector<std::string> names = golden_names();
    ASSERT_FALSE(names.empty()) << "no golden vectors in " << vectors_dir();
    for (const std::string& name : names) {
        ParsedFile f;
        const Bytes bytes = read_bytes(golden_path(name, ".nfc"));
        ASSERT_EQ(parse_file(bytes.data(), bytes.size(), &f), NFD_SUCCESS) << name;
        std::ifstream in(golden_path(name, ".values.txt"));
        ASSERT_TRUE(in) << "missing " << golden_path(name, ".values.txt");
        std::vector<float> points;
        std::vector<double> expected;
        float x, y, z;
        double value;
        while (in >> x >> y >> z >> value) {
            points.insert(points.end(), {x, y, z});
            expected.push_back(value);
        }
        ASSERT_FALSE(expected.empty()) << name;
        std::vector<float> got(expected.size());
        evaluate_cpu(f.geometry.network, points.data(), expected.size(), got.data());
        double worst = 0;
        for (size_t i = 0; i < expected.size(); ++i)
            worst = std::max(worst, std::fabs(double(got[i]) - expected[i]));
        std::printf("%s: %zu points, max |C++ - Python| = %.3g\n", name.c_str(), expected.size(),
                    worst);
        EXPECT_LE(worst, kTolerance) << name;
    }
}

}  // namespace
}  // namespace nfd::test
