// The Vulkan path (gpu/) against its CPU twins: field values vs evaluate_cpu, the range-reduced
// sine vs f64, and meshes vs extract_mesh_cpu (same cells, same welded mesh up to rounding).
// Runs on whatever device create_device() picks, lavapipe on machines without a GPU; skips only
// when no Vulkan device exists at all.
#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <thread>

#include "bitstream.h"
#include "extract.h"
#include "gpu/device.h"
#include "gpu/gpu_decode.h"
#include "test_util.h"

namespace nfd::test {
namespace {

class Gpu : public ::testing::Test {
protected:
    static void SetUpTestSuite() {
        const nfd_result r = gpu::create_device(nullptr, false, &device_);
        if (r != NFD_SUCCESS) device_.reset();
    }
    static void TearDownTestSuite() { device_.reset(); }
    // Skips without a Vulkan driver, unless NFD_REQUIRE_VULKAN is set (scripts/test.sh sets it:
    // CI has lavapipe, so a missing device there is a failure, not a silent skip).
    void SetUp() override {
        if (device_) return;
        const char* required = std::getenv("NFD_REQUIRE_VULKAN");
        if (required && *required && *required != '0') FAIL() << "no Vulkan device";
        GTEST_SKIP() << "no Vulkan device";
    }
    static gpu::Device& device() { return *device_; }
    static std::unique_ptr<gpu::Device> device_;
};
std::unique_ptr<gpu::Device> Gpu::device_;

std::vector<float> random_points(size_t n, uint32_t seed) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<float> u(-1.0f, 1.0f);
    std::vector<float> p(3 * n);
    for (float& x : p) x = u(rng);
    return p;
}

// y = sum of the selected encoded inputs: with one linear layer the field is the encoding itself.
Network encoding_probe(std::vector<float> frequencies, uint32_t column) {
    Network net;
    net.frequencies.assign(frequencies.begin(), frequencies.end());
    Layer out;
    out.in = net.input_width();
    out.out = 1;
    out.weights.assign(out.in, 0.0f);
    out.weights[column] = 1.0f;
    out.bias = {0.0f};
    net.layers.push_back(out);
    return net;
}

// Memory layouts of drivers these tests do not run on, as their vulkaninfo reports them (sizes
// rounded). No device needed: choose_memory_types reads the properties alone.
constexpr VkMemoryPropertyFlags kLocal = VK_MEMORY_PROPERTY_DEVICE_LOCAL_BIT;
constexpr VkMemoryPropertyFlags kHost =
    VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT | VK_MEMORY_PROPERTY_HOST_COHERENT_BIT;
constexpr VkMemoryPropertyFlags kCached = kHost | VK_MEMORY_PROPERTY_HOST_CACHED_BIT;
constexpr VkDeviceSize kGiB = VkDeviceSize(1) << 30;

VkPhysicalDeviceMemoryProperties memory_layout(
    std::initializer_list<std::pair<VkDeviceSize, bool>> heaps,  // size, device-local
    std::initializer_list<std::pair<uint32_t, VkMemoryPropertyFlags>> types) {  // heap, flags
    VkPhysicalDeviceMemoryProperties m{};
    for (const auto& [size, local] : heaps)
        m.memoryHeaps[m.memoryHeapCount++] = {size, local ? VK_MEMORY_HEAP_DEVICE_LOCAL_BIT : 0u};
    for (const auto& [heap, flags] : types) m.memoryTypes[m.memoryTypeCount++] = {flags, heap};
    return m;
}

gpu::MemoryTypes chosen(const VkPhysicalDeviceMemoryProperties& m) {
    gpu::MemoryTypes t;
    EXPECT_TRUE(gpu::choose_memory_types(m, &t));
    return t;
}

TEST(MemoryTypes, DiscreteGpuWithResizableBarIsStagedThroughCachedHostMemory) {
    // NVIDIA H200 (driver 580): VRAM mappable over the whole heap, but not cached.
    const gpu::MemoryTypes t = chosen(memory_layout(
        {{141 * kGiB, true}, {64 * kGiB, false}},
        {{1, 0}, {0, kLocal}, {1, kHost}, {1, kCached}, {0, kLocal | kHost}}));
    EXPECT_EQ(t.device, 1u);
    EXPECT_EQ(t.host, 3u);
    EXPECT_FALSE(t.unified);
}

TEST(MemoryTypes, DiscreteGpuWithBarWindowUsesTheLargestHeap) {
    // RADV on a discrete card without resizable BAR: a 256 MB device-local window.
    const gpu::MemoryTypes t = chosen(memory_layout(
        {{8 * kGiB, true}, {16 * kGiB, false}, {256u << 20, true}},
        {{0, kLocal}, {1, kHost}, {2, kLocal | kHost}, {1, kCached}}));
    EXPECT_EQ(t.device, 0u);
    EXPECT_EQ(t.host, 3u);
    EXPECT_FALSE(t.unified);
}

TEST(MemoryTypes, CpuImplementationsAndIntegratedGpusAreUnified) {
    // lavapipe: one heap, one type with every flag.
    gpu::MemoryTypes t = chosen(memory_layout({{24 * kGiB, true}}, {{0, kLocal | kCached}}));
    EXPECT_EQ(t.device, 0u);
    EXPECT_EQ(t.host, 0u);
    EXPECT_TRUE(t.unified);
    // An integrated GPU (ANV): a plain device-local type listed before the mappable one.
    t = chosen(memory_layout({{16 * kGiB, true}}, {{0, kLocal}, {0, kLocal | kCached}}));
    EXPECT_EQ(t.device, 1u);
    EXPECT_EQ(t.host, 1u);
    EXPECT_TRUE(t.unified);
}

TEST(MemoryTypes, WithoutCachedOrDeviceLocalTypes) {
    // No cached type: host memory falls back to coherent, uncached.
    gpu::MemoryTypes t = chosen(memory_layout({{8 * kGiB, true}, {16 * kGiB, false}},
                                              {{0, kLocal}, {1, kHost}}));
    EXPECT_EQ(t.device, 0u);
    EXPECT_EQ(t.host, 1u);
    EXPECT_FALSE(t.unified);
    // No device-local heap: host memory is all there is.
    t = chosen(memory_layout({{16 * kGiB, false}}, {{0, kHost}, {0, kCached}}));
    EXPECT_EQ(t.device, 1u);
    EXPECT_EQ(t.host, 1u);
    EXPECT_TRUE(t.unified);
    // Nothing the host can map coherently: no context.
    gpu::MemoryTypes none;
    EXPECT_FALSE(gpu::choose_memory_types(
        memory_layout({{8 * kGiB, true}}, {{0, kLocal}, {0, VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT}}),
        &none));
}

TEST_F(Gpu, DeviceHasAName) { EXPECT_STRNE(gpu::device_name(device()), ""); }

// sin and cos of f32 arguments up to ~3000 rad (encoding frequencies reach 489, hidden layers
// omega0 * z) against f64: field_eval.comp reduces them itself, the driver's sin is not trusted.
TEST_F(Gpu, RangeReducedSineMatchesDouble) {
    const std::vector<float> frequencies = {3.14159265f, 489.4f, 1234.5f, 2999.0f};
    const size_t n = 20000;
    std::vector<float> points(3 * n, 0.0f);
    for (size_t i = 0; i < n; ++i) points[3 * i] = -1.0f + 2.0f * float(i) / float(n - 1);
    double worst = 0;
    for (uint32_t k = 0; k < frequencies.size(); ++k) {
        for (uint32_t cosine = 0; cosine < 2; ++cosine) {
            const uint32_t column = 3 + 6 * k + 3 * cosine;  // axis x
            std::vector<float> gpu_values(n);
            ASSERT_EQ(gpu::evaluate(device(), encoding_probe(frequencies, column), points.data(), n,
                                    gpu_values.data()),
                      NFD_SUCCESS);
            for (size_t i = 0; i < n; ++i) {
                const double arg = double(frequencies[k] * points[3 * i]);
                const double want = cosine ? std::cos(arg) : std::sin(arg);
                worst = std::max(worst, std::fabs(gpu_values[i] - want));
            }
        }
    }
    // Cephes-style reduction and polynomials: a few f32 ulps of 1.
    EXPECT_LT(worst, 5e-7) << "max |sin/cos error|";
}

// Random SIRENs of every width the encoder uses (and one beyond a 64 KiB uniform block, which
// takes the storage-buffer variant) against the CPU reference on random points.
TEST_F(Gpu, FieldMatchesCpuForEveryWidth) {
    const std::vector<float> points = random_points(20000, 7);
    const size_t n = points.size() / 3;
    for (uint32_t width : {16u, 24u, 32u, 48u, 64u, 96u, 192u}) {
        const Geometry g = parse_or_throw(geom_file(random_siren(width, 8, 100 + width)));
        std::vector<float> cpu(n), gpu_values(n);
        evaluate_cpu(g.network, points.data(), n, cpu.data());
        ASSERT_EQ(gpu::evaluate(device(), g.network, points.data(), n, gpu_values.data()),
                  NFD_SUCCESS);
        double worst = 0, scale = 0;
        for (size_t i = 0; i < n; ++i) {
            worst = std::max(worst, double(std::fabs(gpu_values[i] - cpu[i])));
            scale = std::max(scale, double(std::fabs(cpu[i])));
        }
        // Both accumulate in f32 in different orders; measured worst ~1e-6 of the output scale.
        EXPECT_LE(worst, 1e-5 * scale) << "width " << width << " scale " << scale;
        RecordProperty("field_max_rel_diff_w" + std::to_string(width), std::to_string(worst / scale));
    }
}

TEST_F(Gpu, EvaluatesMorePointsThanOneInvocationBatch) {
    const Geometry g = parse_or_throw(geom_file(random_siren(16, 8, 3)));
    for (size_t n : {1u, 7u, 9u, 257u}) {
        const std::vector<float> points = random_points(n, uint32_t(n));
        std::vector<float> cpu(n), gpu_values(n, NAN);
        evaluate_cpu(g.network, points.data(), n, cpu.data());
        ASSERT_EQ(gpu::evaluate(device(), g.network, points.data(), n, gpu_values.data()),
                  NFD_SUCCESS);
        for (size_t i = 0; i < n; ++i) EXPECT_NEAR(gpu_values[i], cpu[i], 1e-5) << n << " " << i;
    }
}

// Values and gradients of the WITH_GRADIENT kernel against evaluate_gradient_cpu: a random SDF
// SIREN, a random UDF one (abs output) of width 192 (the storage-buffer variant), and the golden
// vectors (SDF and UDF). Values are also compared with the GPU's own value kernel.
TEST_F(Gpu, GradientMatchesCpu) {
    const std::vector<float> points = random_points(20000, 17);
    const size_t n = points.size() / 3;
    std::vector<Network> networks;
    std::vector<std::string> labels;
    for (const auto& [width, field] : {std::pair<uint32_t, uint8_t>{32, 0}, {192, 1}}) {
        networks.push_back(
            parse_or_throw(geom_file(random_siren(width, 8, 200 + width, field))).network);
        labels.push_back("w" + std::to_string(width) + (field ? "_udf" : "_sdf"));
    }
    for (const std::string& name : golden_names()) {
        ParsedFile f;
        const Bytes bytes = read_bytes(golden_path(name, ".nfc"));
        ASSERT_EQ(parse_file(bytes.data(), bytes.size(), &f), NFD_SUCCESS) << name;
        networks.push_back(f.geometry.network);
        labels.push_back(name);
    }
    for (size_t k = 0; k < networks.size(); ++k) {
        SCOPED_TRACE(labels[k]);
        const Network& net = networks[k];
        std::vector<float> cpu(n), cpu_gradients(3 * n), gpu_values(n), gpu_plain(n),
            gpu_gradients(3 * n);
        evaluate_gradient_cpu(net, points.data(), n, cpu.data(), cpu_gradients.data());
        ASSERT_EQ(gpu::evaluate_gradient(device(), net, points.data(), n, gpu_values.data(),
                                         gpu_gradients.data()),
                  NFD_SUCCESS);
        ASSERT_EQ(gpu::evaluate(device(), net, points.data(), n, gpu_plain.data()), NFD_SUCCESS);
        double worst = 0, scale = 0, worst_gradient = 0, gradient_scale = 0;
        for (size_t i = 0; i < n; ++i) {
            worst = std::max(worst, double(std::fabs(gpu_values[i] - cpu[i])));
            scale = std::max(scale, double(std::fabs(cpu[i])));
            double norm = 0;
            for (int a = 0; a < 3; ++a) {
                const double d = double(gpu_gradients[3 * i + a]) - cpu_gradients[3 * i + a];
                worst_gradient = std::max(worst_gradient, std::fabs(d));
                norm += double(cpu_gradients[3 * i + a]) * cpu_gradients[3 * i + a];
            }
            gradient_scale = std::max(gradient_scale, std::sqrt(norm));
        }
        // As FieldMatchesCpuForEveryWidth: f32 in different orders, range-reduced sin/cos.
        EXPECT_LE(worst, 1e-5 * scale);
        EXPECT_LE(worst_gradient, 1e-5 * gradient_scale);
        RecordProperty("gradient_max_rel_diff_" + labels[k],
                       std::to_string(worst_gradient / gradient_scale));
        for (size_t i = 0; i < n; ++i) ASSERT_EQ(gpu_values[i], gpu_plain[i]) << i;
    }
}

TEST_F(Gpu, GradientOfFewPointsAndOfNone) {
    const Network net = parse_or_throw(geom_file(random_siren(16, 8, 3, 1))).network;
    for (size_t n : {1u, 2u, 3u, 257u}) {
        const std::vector<float> points = random_points(n, uint32_t(n));
        std::vector<float> cpu(n), cpu_gradients(3 * n), values(n, NAN), gradients(3 * n, NAN);
        evaluate_gradient_cpu(net, points.data(), n, cpu.data(), cpu_gradients.data());
        ASSERT_EQ(gpu::evaluate_gradient(device(), net, points.data(), n, values.data(),
                                         gradients.data()),
                  NFD_SUCCESS);
        for (size_t i = 0; i < 3 * n; ++i)
            EXPECT_NEAR(gradients[i], cpu_gradients[i], 1e-4 * (1 + std::fabs(cpu_gradients[i])));
    }
    EXPECT_EQ(gpu::evaluate_gradient(device(), net, nullptr, 0, nullptr, nullptr), NFD_SUCCESS);
}

struct MeshPair {
    MeshData cpu, gpu;
    ExtractStats cpu_stats, gpu_stats;
};

MeshPair extract_both(gpu::Device& device, const Geometry& g, uint32_t resolution) {
    MeshPair m;
    // The CPU twin of the GPU's schedule: the levels by the keep rule (grid.h), a UDF's finest
    // level by surface following within the kept parents.
    EXPECT_EQ(extract_mesh_cpu(g, resolution, &m.cpu, &m.cpu_stats, 0, /*band=*/true,
                               /*follow_finest=*/true),
              NFD_SUCCESS);
    EXPECT_EQ(gpu::extract_mesh(device, g, resolution, &m.gpu, &m.gpu_stats), NFD_SUCCESS);
    return m;
}

// The same mesh: the same cells visited, one vertex per crossed edge at the same place (to float
// rounding of the two evaluators), the same triangles with the same winding, and normals alike.
// A UDF cell's orientation n is the gradient at its corner with the smallest value: where two
// corners tie in exact arithmetic (the symmetric blob has many), the evaluators' last-bit
// differences pick either, and if the two candidates have opposite canonical directions the cell
// takes the complementary case: the same crossed edges, the other winding and possibly the other
// triangulation. `max_differing` bounds the fraction of GPU triangles that such cells change, and
// of vertex normals flipped by the same kind of tie in their canonical direction (step 6).
void expect_same_mesh(const MeshPair& m, const Geometry& g, uint32_t resolution,
                      double max_differing = 0) {
    EXPECT_EQ(m.gpu_stats.points_evaluated, m.cpu_stats.points_evaluated);
    EXPECT_EQ(m.gpu_stats.active_cells, m.cpu_stats.active_cells);
    ASSERT_EQ(m.gpu.vertex_count(), m.cpu.vertex_count());
    ASSERT_EQ(m.gpu.triangle_count(), m.cpu.triangle_count());
    ASSERT_EQ(m.gpu.normals.size(), m.gpu.positions.size());
    const float cell = 2.0f / float(resolution) * g.scale;
    // Measured: at most 1.5e-3 cells (4 of 262642 vertices at resolution 400, where the blob's
    // crossings sit far from the frame's origin), else below 1e-3.
    const std::vector<int64_t> map = match_vertices(m.gpu, m.cpu, cell, 1e-2f * cell);
    size_t flipped_normals = 0;
    for (size_t i = 0; i < map.size(); ++i) {
        ASSERT_GE(map[i], 0) << "GPU vertex " << i << " has no CPU twin";
        float dot = 0;
        for (int a = 0; a < 3; ++a) dot += m.gpu.normals[3 * i + a] * m.cpu.normals[3 * map[i] + a];
        if (max_differing > 0 && dot < 0) ++flipped_normals, dot = -dot;  // a tie, as for n
        ASSERT_GT(dot, 0.999f) << "normal of vertex " << i;
    }
    EXPECT_LE(double(flipped_normals), max_differing * double(m.gpu.vertex_count()));
    const auto gpu_triangles = triangles(m.gpu, &map), cpu_triangles = triangles(m.cpu, nullptr);
    size_t differing = 0;
    for (const auto& t : gpu_triangles) differing += cpu_triangles.count(t) == 0;
    EXPECT_LE(double(differing), max_differing * double(m.gpu.triangle_count()));
    ::testing::Test::RecordProperty("differing_triangles_r" + std::to_string(resolution),
                                    int(differing));
}

// A closed blob in a shifted, scaled frame: watertight, outward, identical to the CPU mesh, at a
// power-of-two resolution, one whose coarse levels drop cells past the last fine vertex (75:
// 38 -> 75), one too small to refine at all (16), and one whose finest level has more new points
// than one evaluation chunk of levels.cpp's record_list (400: 1.3M).
TEST_F(Gpu, MeshMatchesCpuOnClosedBlob) {
    const float center[3] = {1.0f, -2.0f, 0.5f};
    const Geometry g = parse_or_throw(geom_file(closed_blob(3.0f, center)));
    for (uint32_t resolution : {128u, 75u, 16u, 400u}) {
        SCOPED_TRACE("resolution " + std::to_string(resolution));
        const MeshPair m = extract_both(device(), g, resolution);
        ASSERT_GT(m.gpu.triangle_count(), 0u);
        expect_same_mesh(m, g, resolution);
        std::string why;
        EXPECT_TRUE(is_watertight_and_consistent(m.gpu, &why)) << why;
        EXPECT_GT(signed_volume(m.gpu), 0.0) << "triangles face inwards";
    }
}

// NFD_DEVICE_AUTO takes a hardware GPU and declines a CPU implementation (lavapipe), whose name
// its reason then gives, or, with no GPU device node, does not look; NFD_DEVICE_VULKAN takes either.
TEST_F(Gpu, AutoDeclinesACpuImplementation) {
    std::unique_ptr<gpu::Device> hardware;
    std::string declined;
    const nfd_result r = gpu::create_device(nullptr, false, &hardware, true, &declined);
    nfd_context* automatic = nullptr;
    nfd_context* vulkan = nullptr;
    nfd_context_options o{};
    ASSERT_EQ(nfd_context_create(&o, &automatic), NFD_SUCCESS);
    o.device = NFD_DEVICE_VULKAN;
    ASSERT_EQ(nfd_context_create(&o, &vulkan), NFD_SUCCESS);
    EXPECT_STREQ(nfd_context_device_reason(vulkan), "requested");
    if (r == NFD_SUCCESS) {
        EXPECT_EQ(nfd_context_device_kind(automatic), NFD_DEVICE_VULKAN);
        EXPECT_STREQ(nfd_context_device_reason(automatic), "auto: a GPU");
    } else {
        ASSERT_EQ(r, NFD_ERROR_DEVICE_UNAVAILABLE);
        const std::string why = gpu::gpu_device_node_present()
                                    ? std::string("the only Vulkan device, ") + nfd_context_device_name(vulkan) +
                                          ", is a CPU implementation (slower than this path)"
                                    : "no GPU device node (/dev/dri, /dev/nvidia*), so no GPU";
        EXPECT_EQ(declined, why);
        EXPECT_EQ(nfd_context_device_kind(automatic), NFD_DEVICE_CPU);
        EXPECT_EQ(nfd_context_device_reason(automatic), "auto: " + why);
    }
    nfd_context_destroy(automatic);
    nfd_context_destroy(vulkan);
}

// A device of its own, created with the environment variable `force` set (the library's switches
// that run a discrete GPU's choices on lavapipe).
std::unique_ptr<gpu::Device> device_forcing(const char* force) {
    setenv(force, "1", 1);
    std::unique_ptr<gpu::Device> d;
    const nfd_result r = gpu::create_device(nullptr, false, &d);
    unsetenv(force);
    EXPECT_EQ(r, NFD_SUCCESS) << force;
    return d;
}

// A device of its own without the lanes kernels (field_eval.comp's shape on lavapipe too).
std::unique_ptr<gpu::Device> device_without_lanes() {
    std::unique_ptr<gpu::Device> d;
    EXPECT_EQ(gpu::create_device(nullptr, false, &d), NFD_SUCCESS);
    if (d) d->lane_kernels = false;
    return d;
}

// The staged path of discrete GPUs (device-local buffers the host reaches by copies), forced on
// this device: the same values, gradients and meshes, SDF and UDF, as with mapped memory.
TEST_F(Gpu, StagedMemoryGivesTheSameResults) {
    const std::unique_ptr<gpu::Device> staged = device_forcing("NFD_FORCE_STAGING");
    ASSERT_TRUE(staged);
    EXPECT_FALSE(gpu::unified_memory(*staged));
    for (const char* name : {"bunny_sdf_w32", "tshirt_udf_w16"}) {
        SCOPED_TRACE(name);
        const Geometry g = parse_or_throw(read_bytes(golden_path(name, ".nfc")));
        MeshData mapped_mesh, staged_mesh;
        ExtractStats mapped_stats, staged_stats;
        ASSERT_EQ(gpu::extract_mesh(device(), g, 128, &mapped_mesh, &mapped_stats), NFD_SUCCESS);
        ASSERT_EQ(gpu::extract_mesh(*staged, g, 128, &staged_mesh, &staged_stats), NFD_SUCCESS);
        EXPECT_EQ(staged_mesh.positions, mapped_mesh.positions);
        EXPECT_EQ(staged_mesh.normals, mapped_mesh.normals);
        EXPECT_EQ(staged_mesh.indices, mapped_mesh.indices);
        EXPECT_EQ(staged_stats.active_cells, mapped_stats.active_cells);
        const std::vector<float> points = {0.1f, -0.2f, 0.3f, 0.5f, 0.5f, -0.5f};
        std::vector<float> a(2), b(2), ga(6), gb(6);
        ASSERT_EQ(gpu::evaluate_gradient(device(), g.network, points.data(), 2, a.data(),
                                         ga.data()), NFD_SUCCESS);
        ASSERT_EQ(gpu::evaluate_gradient(*staged, g.network, points.data(), 2, b.data(),
                                         gb.data()), NFD_SUCCESS);
        EXPECT_EQ(a, b);
        EXPECT_EQ(ga, gb);
    }
}

// The field kernels' GPU shape (a point per invocation, weights in shared memory; picked on devices
// that are not CPU implementations), forced on this device: the same values, gradients and
// meshes, bit for bit, as field_eval.comp's shape (this device without its lanes kernels, whose
// gradients differ by rounding) on every golden vector, SDF and UDF.
TEST_F(Gpu, SharedWeightKernelsGiveTheSameResults) {
    const std::unique_ptr<gpu::Device> shared = device_forcing("NFD_FORCE_SHARED_WEIGHTS");
    ASSERT_TRUE(shared);
    ASSERT_TRUE(shared->shared_weight_kernels);
    const std::unique_ptr<gpu::Device> plain = device_without_lanes();
    ASSERT_TRUE(plain);
    std::mt19937 rng(5);
    std::uniform_real_distribution<float> u(-1.0f, 1.0f);
    std::vector<float> points(3 * 1000);
    for (float& p : points) p = u(rng);
    for (const std::string& name : golden_names()) {
        SCOPED_TRACE(name);
        const Geometry g = parse_or_throw(read_bytes(golden_path(name, ".nfc")));
        MeshData usual_mesh, shared_mesh;
        ASSERT_EQ(gpu::extract_mesh(*plain, g, 96, &usual_mesh, nullptr), NFD_SUCCESS);
        ASSERT_EQ(gpu::extract_mesh(*shared, g, 96, &shared_mesh, nullptr), NFD_SUCCESS);
        EXPECT_EQ(shared_mesh.indices, usual_mesh.indices);
        EXPECT_EQ(shared_mesh.positions, usual_mesh.positions);
        EXPECT_EQ(shared_mesh.normals, usual_mesh.normals);
        std::vector<float> a(1000), b(1000), ga(3000), gb(3000), cpu(1000);
        ASSERT_EQ(gpu::evaluate_gradient(*plain, g.network, points.data(), 1000, a.data(), ga.data()),
                  NFD_SUCCESS);
        ASSERT_EQ(gpu::evaluate_gradient(*shared, g.network, points.data(), 1000, b.data(), gb.data()),
                  NFD_SUCCESS);
        EXPECT_EQ(a, b);
        EXPECT_EQ(ga, gb);
        evaluate_cpu(g.network, points.data(), 1000, cpu.data());
        for (size_t i = 0; i < cpu.size(); ++i) ASSERT_NEAR(b[i], cpu[i], 1e-5f) << i;
    }
    size_t shared_pipelines = 0;
    for (const gpu::Device::FieldPipeline& f : shared->field_pipelines)
        shared_pipelines += f.kernel == gpu::Kernel::FieldEvalShared || f.kernel == gpu::Kernel::FieldGradientShared;
    EXPECT_GE(shared_pipelines, 2u) << "the shared-memory kernels did not run";
}

// random_siren's first layer (`frequencies`, 8 bits), then `hidden` - 1 more layers of `width`
// at its second layer's steps, then `outputs`.
GeomSpec hidden_siren(uint32_t width, uint32_t frequencies, uint32_t hidden, uint32_t outputs,
                      uint32_t seed, uint8_t field_type) {
    GeomSpec spec = random_siren(width, 8, seed, field_type, uint16_t(outputs), uint8_t(frequencies));
    spec.widths.assign(hidden, uint16_t(width));
    spec.widths.push_back(uint16_t(outputs));
    spec.steps.resize(2 * spec.widths.size(), spec.steps[2]);
    std::mt19937 rng(width);
    std::uniform_int_distribution<int32_t> level(-127, 127);
    spec.levels.resize(width * (spec.input_width() + 1));
    for (uint32_t l = 1; l < spec.widths.size(); ++l)
        for (uint32_t k = 0; k < (spec.widths[l - 1] + 1u) * spec.widths[l]; ++k)
            spec.levels.push_back(level(rng));
    return spec;
}

// On a CPU implementation with 8-wide compute subgroups (lavapipe) the values of networks up to
// 48 wide come from field_eval_lanes.comp, bit for bit field_eval.comp's (so also the gradient
// kernel's values, and every mesh): random networks of the shapes the encoders write (geometry
// and colour, 1-4 sine layers, L = 0-16, widths 4-48), against a device without the lanes kernel;
// a 64-wide network keeps field_eval.comp.
TEST_F(Gpu, LaneKernelGivesTheValueKernelsBits) {
    if (!device().lane_kernels) GTEST_SKIP() << "not a CPU implementation with 8-wide subgroups";
    std::unique_ptr<gpu::Device> lanes;
    ASSERT_EQ(gpu::create_device(nullptr, false, &lanes), NFD_SUCCESS);
    const std::unique_ptr<gpu::Device> plain = device_without_lanes();
    ASSERT_TRUE(plain);
    const std::vector<float> points = random_points(3001, 11);
    const size_t n = points.size() / 3;
    struct Shape { uint32_t width, frequencies, outputs, hidden; };
    const std::vector<Shape> shapes = {{4, 0, 1, 1},  {16, 8, 1, 2}, {24, 5, 1, 2}, {32, 8, 1, 2}, {36, 16, 1, 2},
                                       {48, 8, 1, 2}, {26, 8, 3, 3}, {40, 8, 3, 4}, {64, 8, 1, 2}};
    for (const Shape& shape : shapes) {
        SCOPED_TRACE(testing::Message() << "width " << shape.width << " L " << shape.frequencies
                                        << " outputs " << shape.outputs << " hidden " << shape.hidden);
        GeomSpec spec = hidden_siren(shape.width, shape.frequencies, shape.hidden, shape.outputs,
                                     1000 + shape.width, 0);
        ParsedFile file;
        const Bytes bytes = shape.outputs == 1
                                ? geom_file(spec)
                                : coloured_file(random_siren(16, 8, 1), (spec.output = 2, spec));
        ASSERT_EQ(parse_file(bytes.data(), bytes.size(), &file), NFD_SUCCESS);
        const Network& net = shape.outputs == 1 ? file.geometry.network : *file.colour;
        std::vector<float> with_lanes(n * shape.outputs), usual(n * shape.outputs), cpu(n * shape.outputs);
        ASSERT_EQ(gpu::evaluate(*lanes, net, points.data(), n, with_lanes.data()), NFD_SUCCESS);
        ASSERT_EQ(gpu::evaluate(*plain, net, points.data(), n, usual.data()), NFD_SUCCESS);
        EXPECT_EQ(with_lanes, usual);
        evaluate_cpu(net, points.data(), n, cpu.data());
        for (size_t i = 0; i < cpu.size(); ++i) ASSERT_NEAR(with_lanes[i], cpu[i], 1e-4f) << i;
    }
    size_t lane_pipelines = 0, value_pipelines = 0;
    for (const gpu::Device::FieldPipeline& f : lanes->field_pipelines) {
        lane_pipelines += f.kernel == gpu::Kernel::FieldEvalLanes;
        value_pipelines += f.kernel == gpu::Kernel::FieldEval;
    }
    EXPECT_EQ(lane_pipelines, shapes.size() - 1) << "the lanes kernel did not run";
    EXPECT_EQ(value_pipelines, 1u) << "width 64 did not keep field_eval.comp";
    for (const gpu::Device::FieldPipeline& f : plain->field_pipelines)
        EXPECT_NE(f.kernel, gpu::Kernel::FieldEvalLanes);
}

// The gradient variant of the lanes kernel (CPU implementations, networks up to 48 wide, reverse
// mode on the transposed blocks field.cpp appends): values bit for bit field_eval.comp's, gradients
// within rounding of field_eval.comp's and the CPU twin's, on random UDF networks of 1-4 hidden
// layers, widths 4-48 and L = 0-16 and on every golden vector; on the golden vectors the meshes
// have field_eval.comp's triangles and positions, their normals (the gradients) within 1e-5.
TEST_F(Gpu, LaneGradientKernelMatchesTheGradientKernel) {
    if (!device().lane_kernels) GTEST_SKIP() << "not a CPU implementation with 8-wide subgroups";
    std::unique_ptr<gpu::Device> lanes;
    ASSERT_EQ(gpu::create_device(nullptr, false, &lanes), NFD_SUCCESS);
    const std::unique_ptr<gpu::Device> plain = device_without_lanes();
    ASSERT_TRUE(plain);
    const std::vector<float> points = random_points(3001, 13);
    const size_t n = points.size() / 3;
    struct Shape { uint32_t width, frequencies, hidden; };
    std::vector<Geometry> geometries;
    std::vector<std::string> labels;
    // (Widths 16 and 32 at L = 16: the golden vectors. Each shape is a pipeline of its own,
    // ~10 s to compile the first time on 2-core lavapipe at width 48.)
    for (const Shape& shape : std::vector<Shape>{{4, 0, 1}, {24, 5, 3}, {12, 16, 4}, {48, 8, 2}}) {
        geometries.push_back(parse_or_throw(geom_file(
            hidden_siren(shape.width, shape.frequencies, shape.hidden, 1, 3000 + shape.width, 1))));
        labels.push_back("width " + std::to_string(shape.width) + " L " +
                         std::to_string(shape.frequencies) + " hidden " + std::to_string(shape.hidden));
    }
    for (const std::string& name : golden_names()) {
        geometries.push_back(parse_or_throw(read_bytes(golden_path(name, ".nfc"))));
        labels.push_back(name);
    }
    for (size_t k = 0; k < geometries.size(); ++k) {
        SCOPED_TRACE(labels[k]);
        const Network& net = geometries[k].network;
        std::vector<float> a(n), b(n), ga(3 * n), gb(3 * n), cpu(n), gcpu(3 * n);
        ASSERT_EQ(gpu::evaluate_gradient(*lanes, net, points.data(), n, a.data(), ga.data()), NFD_SUCCESS);
        ASSERT_EQ(gpu::evaluate_gradient(*plain, net, points.data(), n, b.data(), gb.data()), NFD_SUCCESS);
        evaluate_gradient_cpu(net, points.data(), n, cpu.data(), gcpu.data());
        EXPECT_EQ(a, b);
        double worst = 0, worst_cpu = 0, scale = 0;
        for (size_t i = 0; i < 3 * n; ++i) {
            worst = std::max(worst, double(std::fabs(ga[i] - gb[i])));
            worst_cpu = std::max(worst_cpu, double(std::fabs(ga[i] - gcpu[i])));
            scale = std::max(scale, double(std::fabs(gb[i])));
        }
        EXPECT_LE(worst, 1e-5 * scale);
        EXPECT_LE(worst_cpu, 1e-5 * scale);
        if (k + golden_names().size() < geometries.size()) continue;
        MeshData lane_mesh, plain_mesh;
        ASSERT_EQ(gpu::extract_mesh(*lanes, geometries[k], 96, &lane_mesh, nullptr), NFD_SUCCESS);
        ASSERT_EQ(gpu::extract_mesh(*plain, geometries[k], 96, &plain_mesh, nullptr), NFD_SUCCESS);
        EXPECT_EQ(lane_mesh.indices, plain_mesh.indices);
        EXPECT_EQ(lane_mesh.positions, plain_mesh.positions);
        ASSERT_EQ(lane_mesh.normals.size(), plain_mesh.normals.size());
        for (size_t i = 0; i < lane_mesh.normals.size(); ++i)
            ASSERT_NEAR(lane_mesh.normals[i], plain_mesh.normals[i], 1e-5f) << i;
    }
    size_t lane_gradients = 0;
    for (const gpu::Device::FieldPipeline& f : lanes->field_pipelines)
        lane_gradients += f.kernel == gpu::Kernel::FieldGradientLanes;
    EXPECT_GE(lane_gradients, 4u) << "the lanes gradient kernel did not run";
    for (const gpu::Device::FieldPipeline& f : plain->field_pipelines)
        EXPECT_NE(f.kernel, gpu::Kernel::FieldGradientLanes);
}

// Hostile weights that pass the CRC (steps that overflow to inf against levels of +-127, subnormal
// steps, NaN-producing inf - inf sums) through the lanes kernels: no fault, and the old kernel's
// value bits (NaN where it gives NaN).
TEST_F(Gpu, LaneKernelOnHostileWeights) {
    if (!device().lane_kernels) GTEST_SKIP() << "not a CPU implementation with 8-wide subgroups";
    const std::unique_ptr<gpu::Device> plain = device_without_lanes();
    ASSERT_TRUE(plain);
    const std::vector<float> points = random_points(1000, 5);
    const size_t n = points.size() / 3;
    for (const float step : {3.0e38f, 1.0e-45f, 1.0e20f}) {
        SCOPED_TRACE(step);
        GeomSpec spec = random_siren(32, 8, 77);
        for (size_t k = 0; k < spec.steps.size(); k += 2) spec.steps[k] = step;  // every weight step
        ParsedFile file;
        const Bytes bytes = geom_file(spec);
        if (parse_file(bytes.data(), bytes.size(), &file) != NFD_SUCCESS) continue;  // refused: fine
        std::vector<float> lanes(n), usual(n);
        ASSERT_EQ(gpu::evaluate(device(), file.geometry.network, points.data(), n, lanes.data()), NFD_SUCCESS);
        ASSERT_EQ(gpu::evaluate(*plain, file.geometry.network, points.data(), n, usual.data()), NFD_SUCCESS);
        for (size_t i = 0; i < n; ++i)
            ASSERT_TRUE(std::isnan(lanes[i]) ? std::isnan(usual[i]) : lanes[i] == usual[i])
                << i << ": " << lanes[i] << " against " << usual[i];
        // The gradient variant (as a UDF's): no fault, the value kernel's values.
        file.geometry.network.output = OutputActivation::Abs;
        std::vector<float> values(n), gradients(3 * n);
        ASSERT_EQ(gpu::evaluate_gradient(device(), file.geometry.network, points.data(), n,
                                         values.data(), gradients.data()),
                  NFD_SUCCESS);
        for (size_t i = 0; i < n; ++i)
            ASSERT_TRUE(std::isnan(values[i]) ? std::isnan(usual[i]) : values[i] == std::fabs(usual[i]))
                << i;
    }
}

// A network is uploaded once per device: decodes and evaluations of the same content share it
// (another asset object with equal bytes included), a new network is uploaded, and one evicted
// from the cache (past 8 others) is uploaded again.
TEST_F(Gpu, NetworkIsUploadedOncePerDevice) {
    auto geometry = [](uint64_t seed) { return parse_or_throw(geom_file(random_siren(16, 8, seed))); };
    const Geometry a = geometry(9001), a_again = geometry(9001), b = geometry(9002);
    const std::vector<float> point = {0.1f, 0.2f, 0.3f};
    float value;
    MeshData mesh;
    const uint64_t before = gpu::networks_uploaded(device());
    ASSERT_EQ(gpu::extract_mesh(device(), a, 32, &mesh, nullptr), NFD_SUCCESS);
    ASSERT_EQ(gpu::extract_mesh(device(), a_again, 48, &mesh, nullptr), NFD_SUCCESS);
    ASSERT_EQ(gpu::evaluate(device(), a.network, point.data(), 1, &value), NFD_SUCCESS);
    EXPECT_EQ(gpu::networks_uploaded(device()) - before, 1u);
    ASSERT_EQ(gpu::evaluate(device(), b.network, point.data(), 1, &value), NFD_SUCCESS);
    EXPECT_EQ(gpu::networks_uploaded(device()) - before, 2u);
    for (uint64_t seed = 9100; seed < 9108; ++seed)
        ASSERT_EQ(gpu::evaluate(device(), geometry(seed).network, point.data(), 1, &value),
                  NFD_SUCCESS);
    EXPECT_EQ(gpu::networks_uploaded(device()) - before, 10u);
    ASSERT_EQ(gpu::evaluate(device(), a.network, point.data(), 1, &value), NFD_SUCCESS);
    EXPECT_EQ(gpu::networks_uploaded(device()) - before, 11u);  // a was evicted
}

// Small buffers share blocks of device memory (vk_context.h, Context::create_buffer): a decode
// makes far fewer VkDeviceMemory objects than buffers. (Every other test of this file decodes
// through the blocks too, mapped and, in StagedMemoryGivesTheSameResults, staged.)
TEST_F(Gpu, SmallBuffersShareDeviceMemory) {
    for (const std::string name : {"bunny_sdf_w32", "tshirt_udf_w16"}) {
        SCOPED_TRACE(name);
        const Geometry g = parse_or_throw(read_bytes(golden_path(name, ".nfc")));
        const gpu::DeviceMemory before = gpu::device_memory(device());
        MeshData mesh;
        ASSERT_EQ(gpu::extract_mesh(device(), g, 128, &mesh, nullptr), NFD_SUCCESS);
        ASSERT_GT(mesh.triangle_count(), 1000u);
        const gpu::DeviceMemory after = gpu::device_memory(device());
        const uint64_t buffers = after.buffers - before.buffers;
        const uint64_t allocations = after.allocations - before.allocations;
        EXPECT_GT(buffers, 30u);
        EXPECT_LT(allocations * 3, buffers) << allocations << " allocations for " << buffers;
        ::testing::Test::RecordProperty(name + "_buffers", std::to_string(buffers));
        ::testing::Test::RecordProperty(name + "_allocations", std::to_string(allocations));
    }
}

TEST_F(Gpu, MeshMatchesCpuOnRandomSiren) {
    const Geometry g = parse_or_throw(geom_file(random_siren(16, 8, 11)));
    const MeshPair m = extract_both(device(), g, 64);
    ASSERT_GT(m.gpu.triangle_count(), 0u);
    expect_same_mesh(m, g, 64);
}

// The shape's ball on the device (field_eval.comp's push constants): as on the CPU, nothing in
// offset_blob's corner; unbounded, the same mesh as the CPU's (a second upload: the ball is part
// of the network's identity).
TEST_F(Gpu, NothingIsExtractedBeyondTheShapesBall) {
    Geometry g = parse_or_throw(geom_file(offset_blob(1.2f)));
    MeshData mesh;
    ExtractStats stats;
    ASSERT_EQ(gpu::extract_mesh(device(), g, 64, &mesh, &stats), NFD_SUCCESS);
    EXPECT_EQ(mesh.triangle_count(), 0u);
    g.network.ball = ShapeBall{};
    const MeshPair m = extract_both(device(), g, 64);
    ASSERT_GT(m.gpu.triangle_count(), 100u);
    expect_same_mesh(m, g, 64);
}

TEST_F(Gpu, FieldWithoutSurfaceGivesEmptyMesh) {
    GeomSpec s = closed_blob();
    s.levels.back() = 32767;  // output bias: f = g + 1 > 0 everywhere
    const Geometry g = parse_or_throw(geom_file(s));
    MeshData mesh;
    ExtractStats stats;
    ASSERT_EQ(gpu::extract_mesh(device(), g, 64, &mesh, &stats), NFD_SUCCESS);
    EXPECT_EQ(mesh.vertex_count(), 0u);
    EXPECT_EQ(mesh.triangle_count(), 0u);
}

TEST_F(Gpu, RejectsWhatTheCpuRejects) {
    const Geometry g = parse_or_throw(geom_file(closed_blob()));
    MeshData mesh;
    EXPECT_EQ(gpu::extract_mesh(device(), g, NFD_MAX_RESOLUTION + 1, &mesh, nullptr),
              NFD_ERROR_LIMIT_EXCEEDED);
    EXPECT_EQ(gpu::extract_mesh(device(), g, NFD_MIN_RESOLUTION - 1, &mesh, nullptr),
              NFD_ERROR_LIMIT_EXCEEDED);
}

// The UDF mesher (extract.h, steps 1-7) against mesh_udf_cpu: the same near cells and gradient
// points (gradients_evaluated), the same triangles as sets of welded grid edges, positions to
// rounding. |f| of the closed blob (one closed sheet, in a shifted, scaled frame) at a power of
// two, at 75 (coarse levels drop cells past the last vertex), at 16 (no refinement) and at 400
// (more gradient points than one evaluation chunk); a random UDF SIREN (open sheets, boundaries,
// the edge filter at work; no ties, so identical winding).
TEST_F(Gpu, UdfMeshMatchesCpu) {
    const float center[3] = {1.0f, -2.0f, 0.5f};
    GeomSpec blob = closed_blob(3.0f, center);
    blob.field_type = 1;
    blob.output = 1;
    const Geometry g = parse_or_throw(geom_file(blob));
    for (uint32_t resolution : {128u, 75u, 16u, 400u}) {
        SCOPED_TRACE("resolution " + std::to_string(resolution));
        const MeshPair m = extract_both(device(), g, resolution);
        ASSERT_GT(m.gpu.triangle_count(), 0u);
        EXPECT_EQ(m.gpu_stats.gradients_evaluated, m.cpu_stats.gradients_evaluated);
        // Measured: 20 of 53864 triangles differ at 128, 96 of 18284 at 75, 416 at 400.
        expect_same_mesh(m, g, resolution, 0.01);
    }
    const Geometry siren = parse_or_throw(geom_file(random_siren(16, 8, 11, /*field_type=*/1)));
    const MeshPair m = extract_both(device(), siren, 64);
    ASSERT_GT(m.gpu.triangle_count(), 0u);
    EXPECT_EQ(m.gpu_stats.gradients_evaluated, m.cpu_stats.gradients_evaluated);
    expect_same_mesh(m, siren, 64);
}

// A UDF's finest level follows the surface within the kept parents (levels.h,
// evaluate_finest_flood), or with `band` evaluates all their child grids, those points it expects
// to be near-cell corners with their gradients, which the mesher copies (FinestLevel::predicted),
// unless that list would exceed the device's predicted_list_bytes: the same mesh, bit for bit,
// all three ways, on every UDF golden vector and at a resolution whose finest level has more
// points to evaluate than one evaluation chunk; the two band paths the same counts, the flood
// its CPU twin's (GridBuilder's follow_finest, to the evaluators' last bits) and far fewer
// evaluations.
TEST_F(Gpu, FloodAndPredictedGradientsGiveTheSameMesh) {
    std::unique_ptr<gpu::Device> unpredicted;
    ASSERT_EQ(gpu::create_device(nullptr, false, &unpredicted), NFD_SUCCESS);
    unpredicted->predicted_list_bytes = 0;
    std::vector<std::pair<std::string, uint32_t>> cases;
    for (const std::string& name : golden_names())
        if (name.find("_udf_") != std::string::npos) cases.emplace_back(name, 128u);
    ASSERT_GE(cases.size(), 3u);
    cases.emplace_back("tshirt_udf_w16", 512u);
    for (const auto& [name, resolution] : cases) {
        SCOPED_TRACE(name + " at " + std::to_string(resolution));
        const Geometry g = parse_or_throw(read_bytes(golden_path(name, ".nfc")));
        MeshData flood_mesh, predicted_mesh, plain_mesh, twin_mesh;
        ExtractStats flood_stats, predicted_stats, plain_stats, twin_stats;
        ASSERT_EQ(gpu::extract_mesh(device(), g, resolution, &flood_mesh, &flood_stats),
                  NFD_SUCCESS);
        ASSERT_EQ(gpu::extract_mesh(device(), g, resolution, &predicted_mesh, &predicted_stats,
                                    /*band=*/true),
                  NFD_SUCCESS);
        ASSERT_EQ(gpu::extract_mesh(*unpredicted, g, resolution, &plain_mesh, &plain_stats),
                  NFD_SUCCESS);
        ASSERT_EQ(extract_mesh_cpu(g, resolution, &twin_mesh, &twin_stats, 0, true, true),
                  NFD_SUCCESS);
        ASSERT_GT(plain_mesh.triangle_count(), 0u);
        for (const MeshData* m : {&flood_mesh, &predicted_mesh}) {
            EXPECT_EQ(m->positions, plain_mesh.positions);
            EXPECT_EQ(m->normals, plain_mesh.normals);
            EXPECT_EQ(m->indices, plain_mesh.indices);
        }
        EXPECT_EQ(predicted_stats.points_evaluated, plain_stats.points_evaluated);
        // The flood's edge tests on the two evaluators' values, which differ in their last bits:
        // one point in 2.4M apart on the T-shirt at 512 (measured), none at 128.
        EXPECT_NEAR(double(flood_stats.points_evaluated), double(twin_stats.points_evaluated),
                    1e-5 * double(twin_stats.points_evaluated));
        EXPECT_LT(flood_stats.points_evaluated * 4, plain_stats.points_evaluated * 3);
        for (const ExtractStats* s : {&flood_stats, &predicted_stats}) {
            EXPECT_EQ(s->gradients_evaluated, plain_stats.gradients_evaluated);
            EXPECT_EQ(s->active_cells, plain_stats.active_cells);
        }
    }
}

// A network's shape read ahead of its weights (peek_geometry_network, as nfd_stream does for
// nfd_stream_options.prepare_context) compiles the very pipelines its decode uses: the value
// kernel's, and for a UDF the gradient kernel's. The decode then compiles nothing, and its mesh
// is the CPU twin's as ever.
TEST_F(Gpu, PipelinesCompiledFromTheShapeAreTheDecodesOwn) {
    for (uint8_t field_type : {0, 1}) {
        SCOPED_TRACE(field_type ? "udf" : "sdf");
        // A shape no other test decodes (width 20, 5 frequencies): nothing is compiled for it yet.
        const Bytes bytes = geom_file(random_siren(20, 8, 70 + field_type, field_type, 1, 5));
        const Geometry g = parse_or_throw(bytes);
        Network shape;
        ASSERT_TRUE(peek_geometry_network(&bytes[24], 64, &shape));
        const size_t before = device().field_pipelines.size(), expected = before + 1 + field_type;
        gpu::warm_field_pipelines(device(), shape, g.field);
        device().join_warmers(false);
        EXPECT_EQ(device().field_pipelines.size(), expected);
        for (const gpu::Device::FieldPipeline& f : device().field_pipelines) EXPECT_TRUE(f.ready);
        const MeshPair m = extract_both(device(), g, 48);
        EXPECT_EQ(device().field_pipelines.size(), expected) << "the decode compiled its own";
        ASSERT_GT(m.gpu.triangle_count(), 0u);
        expect_same_mesh(m, g, 48);
    }
}

// field_ready, which decides whether a meshed level above the finest splits its new points
// (levels.h, LevelBuilder), reports exactly the pipelines built, and builds none itself.
TEST_F(Gpu, FieldReadyReportsTheBuiltPipelinesOnly) {
    // A shape no other test decodes (width 20, 4 frequencies): nothing is compiled for it yet.
    const Geometry g = parse_or_throw(geom_file(random_siren(20, 8, 74, /*field_type=*/1, 1, 4)));
    std::shared_ptr<gpu::DeviceNetwork> net;
    ASSERT_EQ(gpu::device_network(device(), g.network, &net), NFD_SUCCESS);
    const size_t before = device().field_pipelines.size();
    EXPECT_FALSE(gpu::field_ready(device(), *net, false));
    EXPECT_FALSE(gpu::field_ready(device(), *net, true));
    EXPECT_EQ(device().field_pipelines.size(), before);
    ASSERT_EQ(gpu::prepare_field(device(), *net, false), NFD_SUCCESS);
    EXPECT_TRUE(gpu::field_ready(device(), *net, false));
    EXPECT_FALSE(gpu::field_ready(device(), *net, true));
    // Compiled for the shape by another path (a read-ahead's warmer), not through this network.
    gpu::warm_field_pipelines(device(), g.network, g.field);
    device().join_warmers(false);
    EXPECT_TRUE(gpu::field_ready(device(), *net, true));
    EXPECT_EQ(device().field_pipelines.size(), before + 2);
}

// Decodes of a new network shape on several threads at once, each compiling what it needs while
// a read-ahead compiles the same: every pipeline is compiled once, and each mesh is the CPU twin's.
TEST_F(Gpu, ConcurrentDecodesOfANewShapeCompileItOnce) {
    const Geometry g = parse_or_throw(geom_file(random_siren(24, 8, 72, /*field_type=*/1, 1, 6)));
    const size_t before = device().field_pipelines.size();
    gpu::warm_field_pipelines(device(), g.network, g.field);
    std::vector<MeshData> meshes(3);
    std::vector<nfd_result> results(3, NFD_ERROR_INTERNAL);
    std::vector<std::thread> threads;
    for (size_t i = 0; i < meshes.size(); ++i)
        threads.emplace_back(
            [&, i] { results[i] = gpu::extract_mesh(device(), g, 40, &meshes[i], nullptr); });
    for (std::thread& t : threads) t.join();
    device().join_warmers(false);
    EXPECT_EQ(device().field_pipelines.size(), before + 2);
    const MeshPair m = extract_both(device(), g, 40);
    for (size_t i = 0; i < meshes.size(); ++i) {
        ASSERT_EQ(results[i], NFD_SUCCESS);
        EXPECT_EQ(meshes[i].indices, m.gpu.indices);
        EXPECT_EQ(meshes[i].positions, m.gpu.positions);
    }
}

// nfd_stream_options.prepare_context through the C API: a stream fed a byte at a time on a
// Vulkan context gives the mesh of the one-shot asset on that context, byte for byte; and the
// context may be destroyed while the compile it was asked for runs (it waits for it), the stream
// then finishing without it.
TEST_F(Gpu, StreamThatPreparesItsContextDecodesAsWithout) {
    nfd_context_options co{};
    co.struct_size = sizeof co;
    co.device = NFD_DEVICE_VULKAN;
    auto mesh_arrays = [](nfd_context* c, const nfd_asset* a) {
        nfd_mesh_options mo{};
        mo.struct_size = sizeof mo;
        mo.resolution = 64;
        nfd_mesh* mesh = nullptr;
        EXPECT_EQ(nfd_mesh_extract(c, a, &mo, &mesh), NFD_SUCCESS);
        nfd_mesh_data d{};
        EXPECT_EQ(nfd_mesh_get_data(mesh, &d), NFD_SUCCESS);
        std::vector<float> out(d.positions, d.positions + 3 * d.vertex_count);
        out.insert(out.end(), d.indices, d.indices + 3 * d.triangle_count);  // exact as floats
        nfd_mesh_destroy(mesh);
        return out;
    };
    for (const char* name : {"bunny_sdf_w16", "tshirt_udf_w16"}) {
        SCOPED_TRACE(name);
        const Bytes bytes = read_bytes(golden_path(name, ".nfc"));
        nfd_context* context = nullptr;
        ASSERT_EQ(nfd_context_create(&co, &context), NFD_SUCCESS);
        nfd_stream_options so{};
        so.struct_size = sizeof so;
        so.prepare_context = context;
        nfd_stream* stream = nullptr;
        ASSERT_EQ(nfd_stream_create(&so, &stream), NFD_SUCCESS);
        for (size_t i = 0; i < bytes.size(); ++i)
            ASSERT_EQ(nfd_stream_feed(stream, &bytes[i], 1, nullptr), NFD_SUCCESS);
        nfd_asset *streamed = nullptr, *whole = nullptr;
        ASSERT_EQ(nfd_stream_finish(stream), NFD_SUCCESS);
        ASSERT_EQ(nfd_stream_take_complete_asset(stream, &streamed), NFD_SUCCESS);
        nfd_stream_destroy(stream);
        ASSERT_EQ(nfd_asset_create(bytes.data(), bytes.size(), &whole), NFD_SUCCESS);
        EXPECT_EQ(mesh_arrays(context, streamed), mesh_arrays(context, whole));
        nfd_asset_destroy(streamed);
        nfd_asset_destroy(whole);
        nfd_context_destroy(context);

        ASSERT_EQ(nfd_context_create(&co, &context), NFD_SUCCESS);
        so.prepare_context = context;
        ASSERT_EQ(nfd_stream_create(&so, &stream), NFD_SUCCESS);
        ASSERT_EQ(nfd_stream_feed(stream, bytes.data(), 80, nullptr), NFD_SUCCESS);
        nfd_context_destroy(context);  // waits for the compile the stream started
        ASSERT_EQ(nfd_stream_feed(stream, &bytes[80], bytes.size() - 80, nullptr), NFD_SUCCESS);
        EXPECT_EQ(nfd_stream_finish(stream), NFD_SUCCESS);
        nfd_stream_destroy(stream);
    }
}

// Golden vectors from the Python encoder (SDF and UDF): GPU mesh vs CPU mesh.
TEST_F(Gpu, GoldenVectorMeshesMatchCpu) {
    const std::vector<std::string> names = golden_names();
    ASSERT_FALSE(names.empty()) << "no golden vectors in " << vectors_dir();
    for (const std::string& name : names) {
        SCOPED_TRACE(name);
        ParsedFile f;
        const Bytes bytes = read_bytes(golden_path(name, ".nfc"));
        ASSERT_EQ(parse_file(bytes.data(), bytes.size(), &f), NFD_SUCCESS);
        const MeshPair m = extract_both(device(), f.geometry, 128);
        // Values agree to ~1e-6, so a grid point can only change sign where |f| is that small:
        // allow a handful of differing vertices, but the surfaces must coincide.
        const double n = double(m.cpu.vertex_count()), t = double(m.cpu.triangle_count());
        EXPECT_NEAR(double(m.gpu.vertex_count()), n, 1e-3 * n + 2);
        EXPECT_NEAR(double(m.gpu.triangle_count()), t, 1e-3 * t + 4);  // measured: all equal
        EXPECT_NEAR(double(m.gpu_stats.gradients_evaluated),
                    double(m.cpu_stats.gradients_evaluated),
                    1e-3 * double(m.cpu_stats.gradients_evaluated) + 2);
        EXPECT_LT(chamfer(m.gpu.positions, m.cpu.positions), 1e-4 * f.geometry.scale);
    }
}

// The coarsest level is evaluated on the host, by the C++ evaluator (gpu/levels.h, HostTop), so
// that a first level needs none of the network's pipelines: a decode at a resolution that is its
// own coarsest level (32) has the CPU path's values and, for a UDF, gradients bit for bit, hence
// the same cells, the same gradient count, the same triangles and vertices to the meshers'
// rounding, on every golden vector.
TEST_F(Gpu, CoarsestLevelIsTheCppEvaluators) {
    for (const std::string& name : golden_names()) {
        SCOPED_TRACE(name);
        ParsedFile f;
        const Bytes bytes = read_bytes(golden_path(name, ".nfc"));
        ASSERT_EQ(parse_file(bytes.data(), bytes.size(), &f), NFD_SUCCESS);
        const MeshPair m = extract_both(device(), f.geometry, 32);
        EXPECT_EQ(m.gpu_stats.gradients_evaluated, m.cpu_stats.gradients_evaluated);
        expect_same_mesh(m, f.geometry, 32);
        // The vertices differ by the two meshers' rounding only: far below the ~1e-3 cells of
        // values from the GPU's field kernel (expect_same_mesh's measurement).
        const float cell = 2.0f / 32.0f * f.geometry.scale;
        const std::vector<int64_t> map = match_vertices(m.gpu, m.cpu, cell, 1e-5f * cell);
        EXPECT_EQ(std::count(map.begin(), map.end(), int64_t(-1)), 0);
    }
}

}  // namespace
}  // namespace nfd::test

namespace nfd::test {
namespace {

// Hostile values that parse (some give inf or NaN fields) mesh on the GPU too, finite or empty:
// at 16 (the coarsest level is the finest), and at 64 through a refined finest level, by surface
// following (udf_flood.comp) and by the band (sample_band).
TEST_F(Gpu, AcceptedUdfDamageMeshesFiniteOrEmpty) {
    size_t meshed = 0;
    // ~17 files, three decodes each: several seconds on lavapipe.
    for_each_accepted_damage(geom_payload(random_siren(8, 8, 7, /*field_type=*/1)), 53, {0xFF},
                             [&](size_t i, const Geometry& g) {
                                 for (auto [resolution, band] : {std::pair{16u, false},
                                                                 std::pair{64u, false},
                                                                 std::pair{64u, true}}) {
                                     MeshData m;
                                     ExtractStats stats;
                                     ASSERT_EQ(gpu::extract_mesh(device(), g, resolution, &m,
                                                                 &stats, band),
                                               NFD_SUCCESS)
                                         << i << " at " << resolution << ", band " << band;
                                     ASSERT_TRUE(is_finite_mesh(m)) << i << " at " << resolution;
                                     meshed += m.triangle_count() > 0;
                                 }
                             });
    EXPECT_GT(meshed, 0u);
}

// The same damage through a progressive extraction that meshes every level: at 128 the 64 level
// is meshed above the finest, so its new points are split, evaluated and joined back
// (udf_predict.comp's NFD_PREDICT_JOIN) before the finest level refines them. Every level a
// finite mesh, or the step an error code.
TEST_F(Gpu, AcceptedUdfDamageGivesFiniteProgressiveLevelsOrErrors) {
    size_t meshed = 0, finished = 0;
    for_each_accepted_damage(geom_payload(random_siren(8, 8, 7, /*field_type=*/1)), 107, {0xFF},
                             [&](size_t i, const Geometry& g) {
                                 std::unique_ptr<Extraction> ex;
                                 ASSERT_EQ(gpu::make_extraction(device(), g, 128, 0b111, false, &ex),
                                           NFD_SUCCESS)
                                     << i;
                                 bool done = false;
                                 while (!done) {
                                     MeshData m;
                                     ExtractStats stats;
                                     LevelReport report;
                                     if (ex->step(&m, &stats, &report) != NFD_SUCCESS) break;
                                     ASSERT_TRUE(is_finite_mesh(m)) << i << " level " << report.level;
                                     meshed += m.triangle_count() > 0;
                                     done = report.done;
                                 }
                                 finished += done;
                             });
    EXPECT_GT(meshed, 0u);
    EXPECT_GT(finished, 0u);  // some files reach the finest level, through the joined one
}

}  // namespace
}  // namespace nfd::test
