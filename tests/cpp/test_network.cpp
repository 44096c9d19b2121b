// The CPU evaluator against an f64 reimplementation (synthetic networks) and against the Python
// reference decoder's values (golden vectors); its gradients against f64 finite differences.
//
// Tolerance: |C++ f32 - reference| <= 1e-5 in unit-frame distance, i.e. 0.01% of the truncation
// band d* = 0.1 and far below a cell at resolution 1024 (0.002). The f32 path's actual error on
// these networks is about 5e-8 (printed by the tests); the margin covers trained weights, which are
// larger than at initialisation.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <cstring>

#include "sine.h"
#include "test_util.h"

namespace nfd::test {
namespace {

constexpr double kTolerance = 1e-5;

// sine.h: within 1.5 f32 ulps of 1 (absolute 1.8e-7) of the f64 sine and cosine over the
// evaluator's arguments (encoding products up to ~490, hidden omega0 z up to a few thousand),
// sin_reduced equal to sincos_reduced's sine bit for bit, and no undefined behaviour (UBSan
// builds) or non-number from finite arguments far beyond the accurate range.
TEST(Sine, AccurateOverTheEvaluatorsArguments) {
    std::mt19937 rng(3);
    std::vector<float> x;
    for (float range : {1.0f, 10.0f, 500.0f, 8000.0f}) {
        std::uniform_real_distribution<float> u(-range, range);
        for (int i = 0; i < 20000; ++i) x.push_back(u(rng));
    }
    for (int k = -64; k <= 64; ++k) {  // at and next to multiples of pi/2
        const float at = float(k * M_PI / 2);
        x.insert(x.end(), {at, std::nextafter(at, 1e9f), std::nextafter(at, -1e9f)});
    }
    std::vector<float> s(x.size()), c(x.size()), s_only(x.size());
    sincos_reduced(x.data(), s.data(), c.data(), x.size());
    sin_reduced(x.data(), s_only.data(), x.size());
    double worst = 0;
    for (size_t i = 0; i < x.size(); ++i) {
        worst = std::max({worst, std::fabs(s[i] - std::sin(double(x[i]))),
                          std::fabs(c[i] - std::cos(double(x[i])))});
        ASSERT_EQ(std::memcmp(&s[i], &s_only[i], 4), 0) << x[i];
    }
    std::printf("sine.h: max |error| = %.3g over %zu arguments\n", worst, x.size());
    EXPECT_LE(worst, 1.8e-7);

    const float far[] = {1e6f, -3e7f, 1e30f, -3.4e38f, 0.0f, -0.0f};
    float fs[6], fc[6];
    sincos_reduced(far, fs, fc, 6);
    for (int i = 0; i < 6; ++i) EXPECT_TRUE(std::isfinite(fs[i]) && std::isfinite(fc[i])) << far[i];
    EXPECT_EQ(fs[4], 0.0f);
    EXPECT_EQ(fc[4], 1.0f);
    const float special[] = {INFINITY, -INFINITY, NAN};
    sincos_reduced(special, fs, fc, 3);
    for (int i = 0; i < 3; ++i) EXPECT_TRUE(std::isnan(fs[i]) && std::isnan(fc[i]));
}

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

// The field as a smooth function of f64 coordinates (evaluate_f64 rounds the encoding products
// f * u to f32 as FORMAT.md specifies, which is a staircase at the scale of finite differences).
double smooth_field_f64(const Network& net, const double u[3]) {
    std::vector<double> h(u, u + 3);
    for (int trig = 0; trig < 2 * int(net.frequencies.size()); ++trig)
        for (int j = 0; j < 3; ++j) {
            const double arg = double(net.frequencies[trig / 2]) * u[j];
            h.push_back(trig % 2 ? std::cos(arg) : std::sin(arg));
        }
    for (size_t l = 0; l < net.layers.size(); ++l) {
        const Layer& layer = net.layers[l];
        std::vector<double> next(layer.bias.begin(), layer.bias.end());
        for (uint32_t o = 0; o < layer.out; ++o) {
            for (uint32_t i = 0; i < layer.in; ++i)
                next[o] += double(layer.weights[o * layer.in + i]) * h[i];
            if (l + 1 < net.layers.size()) next[o] = std::sin(double(net.omega0) * next[o]);
        }
        h.swap(next);
    }
    if (net.output == OutputActivation::Abs) return std::fabs(h[0]);
    if (net.output == OutputActivation::Sigmoid) return 1.0 / (1.0 + std::exp(-h[0]));
    return h[0];
}

// Worst |analytic - central difference| over the points, relative to the largest gradient norm.
// Step 1e-6 in f64: the truncation error h^2 |f'''| / 6, with |f'''| up to ~1e9 for these SIRENs
// (top frequency ~489, omega0 = 30), stays ~1e-4 on gradients of norm 10-1000, and rounding
// (1e-16 / 1e-6) is negligible: the comparison measures the f32 analytic path.
double gradient_error_vs_differences(const Network& net, const std::vector<float>& points) {
    const size_t n = points.size() / 3;
    std::vector<float> values(n), gradients(3 * n);
    evaluate_gradient_cpu(net, points.data(), n, values.data(), gradients.data());
    double worst = 0, scale = 0;
    for (size_t i = 0; i < n; ++i) {
        const double u[3] = {points[3 * i], points[3 * i + 1], points[3 * i + 2]};
        // A UDF's abs has a kink at 0: differences across it are meaningless.
        if (net.output == OutputActivation::Abs && std::fabs(smooth_field_f64(net, u)) < 1e-2)
            continue;
        double norm = 0;
        for (int a = 0; a < 3; ++a) {
            const double h = 1e-6;
            double lo[3] = {u[0], u[1], u[2]}, hi[3] = {u[0], u[1], u[2]};
            lo[a] -= h;
            hi[a] += h;
            const double fd = (smooth_field_f64(net, hi) - smooth_field_f64(net, lo)) / (2 * h);
            worst = std::max(worst, std::fabs(gradients[3 * i + a] - fd));
            norm += fd * fd;
        }
        scale = std::max(scale, std::sqrt(norm));
    }
    return worst / scale;
}

// Relative to the largest gradient norm. The limit is the encoding, not the forward pass: FORMAT.md
// rounds f * u to f32 (half an ulp of ~540 rad is 3e-5 rad at the top frequency ~489 and |u| <=
// 1.1), so the derivative f cos(f u) of that term is off by up to ~3e-5 of its size. Measured
// (printed): 1.3e-5 on random SIRENs, 1e-6..5e-6 on the golden vectors; a step of 1e-5 or 1e-7
// gives the same figures, so the differences are not the limit.
constexpr double kGradientTolerance = 5e-5;

// Values against f64, and gradients (evaluate_gradient_cpu) against finite differences.
TEST(Network, MatchesF64ReferenceOnRandomSirens) {
    struct Case {
        uint32_t width;
        uint8_t bits, field;
    };
    for (const Case c : {Case{16, 8, 0}, Case{32, 8, 0}, Case{96, 12, 0}, Case{32, 8, 1}}) {
        const Geometry g = parse_or_throw(geom_file(random_siren(c.width, c.bits, c.width, c.field)));
        // Points inside the unit cube and beyond it (the extractor's last cells reach past 1).
        const std::vector<float> points = random_points(5000, 42, 1.1f);
        const double err = max_error_vs_f64(g.network, points);
        const double gradient_err = gradient_error_vs_differences(g.network, points);
        std::printf("width %u, %u bits, field %u: max |f32 - f64| = %.3g, gradient %.3g\n",
                    c.width, c.bits, c.field, err, gradient_err);
        EXPECT_LE(err, kTolerance);
        EXPECT_LE(gradient_err, kGradientTolerance);
    }
}

// network.h, ShapeBall (and reference.py's shape_ball_bound, tested on the same points): on the
// sphere of radius 1 + 2 d* a value stays; beyond it a value below d* is raised to d*; a NaN stays.
TEST(ShapeBall, RaisesValuesBeyondTheShapesBallOnly) {
    const ShapeBall ball = ShapeBall::of_truncation(0.1f);
    const float points[] = {1.2f, 0, 0, 1.21f, 0, 0, 0.7f, 0.7f, 0.72f, 0.7f, 0.7f, 0.6f, 2, 0, 0, 2, 0, 0};
    float values[] = {-1, -1, 0.05f, 0.05f, NAN, 0.5f};
    ball.bound(points, 6, values);
    EXPECT_EQ(values[0], -1.0f);
    EXPECT_EQ(values[1], 0.1f);
    EXPECT_EQ(values[2], 0.1f);
    EXPECT_EQ(values[3], 0.05f);
    EXPECT_TRUE(std::isnan(values[4]));
    EXPECT_EQ(values[5], 0.5f);
    float unbounded = -1;
    ShapeBall{}.bound(points + 12, 1, &unbounded);
    EXPECT_EQ(unbounded, -1.0f);
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

// Every vector width the CPU evaluator is built for that this machine runs (network.h,
// set_cpu_evaluator_lanes: AVX-512, AVX2, baseline) computes the same values and gradients, bit for
// bit: widths that are and are not multiples of the output blocks, point counts that end inside a
// group of lanes, a colour network's three outputs.
TEST(Network, EveryVectorWidthComputesTheSameBits) {
    const unsigned widest = set_cpu_evaluator_lanes(0);
    ParsedFile coloured;
    const Bytes bytes = coloured_file(closed_blob(), random_colour_siren(17, 6, 2));
    ASSERT_EQ(parse_file(bytes.data(), bytes.size(), &coloured), NFD_SUCCESS);
    const std::pair<Network, size_t> cases[] = {
        {parse_or_throw(geom_file(random_siren(32, 8, 9, 1))).network, 20011},
        {parse_or_throw(geom_file(random_siren(23, 8, 4, 0, 1, 5))).network, 4133},
        {*coloured.colour, 999}};
    for (const auto& [net, n] : cases) {
        const std::vector<float> p = random_points(n, 5, 1.1f);
        const size_t outputs = net.output_width();
        std::vector<float> values(outputs * n), gradients(3 * n), values_w(outputs * n),
            gradients_w(3 * n), with_gradients(n);
        set_cpu_evaluator_lanes(0);
        evaluate_cpu(net, p.data(), n, values.data(), 2);
        if (outputs == 1)
            evaluate_gradient_cpu(net, p.data(), n, with_gradients.data(), gradients.data(), 2);
        for (unsigned lanes = widest / 2; lanes >= 1; lanes /= 2) {
            const unsigned used = set_cpu_evaluator_lanes(lanes);
            if (used > lanes) break;  // no narrower build
            std::printf("width %u: %u lanes against %u\n", net.layers[0].out, used, widest);
            evaluate_cpu(net, p.data(), n, values_w.data(), 2);
            EXPECT_EQ(std::memcmp(values.data(), values_w.data(), 4 * values.size()), 0) << used;
            if (outputs != 1) continue;
            evaluate_gradient_cpu(net, p.data(), n, with_gradients.data(), gradients_w.data(), 2);
            EXPECT_EQ(std::memcmp(values.data(), with_gradients.data(), 4 * n), 0) << used;
            EXPECT_EQ(std::memcmp(gradients.data(), gradients_w.data(), 4 * gradients.size()), 0)
                << used;
        }
    }
    set_cpu_evaluator_lanes(0);
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
// written by the Python reference decoder (f64) for v1_0_<name>.nfc; gradients against finite
// differences.
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
        const double gradient_err =
            gradient_error_vs_differences(f.geometry.network, random_points(2000, 8));
        std::printf("%s: %zu points, max |C++ - Python| = %.3g, gradient %.3g\n", name.c_str(),
                    expected.size(), worst, gradient_err);
        EXPECT_LE(worst, kTolerance) << name;
        EXPECT_LE(gradient_err, kGradientTolerance) << name;
    }
}


// The value path of evaluate_gradient_cpu is evaluate_cpu's, bit for bit, whatever the blocking
// and threading.
TEST(NetworkGradient, ValuesAreEvaluateCpuValues) {
    const Network net = parse_or_throw(geom_file(random_siren(32, 8, 9))).network;
    const size_t n = 20011;
    const std::vector<float> p = random_points(n, 9, 1.1f);
    std::vector<float> values(n), with_gradient(n), g1(3 * n), g3(3 * n);
    evaluate_cpu(net, p.data(), n, values.data());
    evaluate_gradient_cpu(net, p.data(), n, with_gradient.data(), g1.data(), 1);
    for (size_t i = 0; i < n; ++i) ASSERT_EQ(with_gradient[i], values[i]) << i;
    evaluate_gradient_cpu(net, p.data(), n, with_gradient.data(), g3.data(), 3);
    EXPECT_EQ(g1, g3);
    evaluate_gradient_cpu(net, p.data(), 0, nullptr, nullptr);
}

// The output activations' chain rule against the identity network's gradient: abs multiplies by
// sign(y) (+1 at 0) exactly, sigmoid by s (1 - s).
TEST(NetworkGradient, OutputActivations) {
    Network net = parse_or_throw(geom_file(random_siren(16, 8, 7))).network;
    const size_t n = 500;
    std::vector<float> p = random_points(n, 7);
    std::vector<float> y(n), v(n), dy(3 * n), dv(3 * n);
    evaluate_gradient_cpu(net, p.data(), n, y.data(), dy.data());
    net.output = OutputActivation::Abs;
    evaluate_gradient_cpu(net, p.data(), n, v.data(), dv.data());
    EXPECT_TRUE(std::any_of(y.begin(), y.end(), [](float x) { return x < 0; }));
    for (size_t i = 0; i < 3 * n; ++i) ASSERT_EQ(dv[i], y[i / 3] >= 0.0f ? dy[i] : -dy[i]) << i;
    net.output = OutputActivation::Sigmoid;
    evaluate_gradient_cpu(net, p.data(), n, v.data(), dv.data());
    for (size_t i = 0; i < 3 * n; ++i) {
        const double s = 1.0 / (1.0 + std::exp(-double(y[i / 3])));
        ASSERT_NEAR(dv[i], s * (1 - s) * dy[i], 1e-6 * (std::fabs(dy[i]) + 1)) << i;
    }
}

}  // namespace
}  // namespace nfd::test
