// Field evaluation throughput of libnfdecode's paths (issue 11): nfd_asset_evaluate over a fixed
// set of points, per file, on the C++ path with 1 thread and with every core, and on Vulkan when
// asked. Prints a markdown table: points per second and GFLOP/s, counting 2 flops per weight of
// the network's linear layers (the multiply-adds; sines, the encoding and the output are extra
// work not counted), best of --repeat runs, wall and process CPU time. With --gradients it times
// nfd_asset_evaluate_gradient instead and counts 4 flops per weight (the forward pass's
// multiply-adds and the backward pass's through the transposed weights). "first call ms" is the
// context's first evaluation of 4,096 points: on Vulkan mostly the creation of the network's
// field pipeline, which a process pays once per network shape (from Mesa's disk cache when warm).
//   field_eval [--points N] [--repeat K] [--vulkan] [--gradients] FILE.nfc...
#include <nfdecode/nfdecode.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <ctime>
#include <fstream>
#include <iterator>
#include <random>
#include <string>
#include <thread>
#include <vector>

namespace {

using Clock = std::chrono::steady_clock;

std::vector<unsigned char> read_file(const char* path) {
    std::ifstream in(path, std::ios::binary);
    if (!in) {
        std::fprintf(stderr, "field_eval: cannot open %s\n", path);
        std::exit(1);
    }
    return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

void check(nfd_result r, const char* what) {
    if (r == NFD_SUCCESS) return;
    std::fprintf(stderr, "field_eval: %s: %s\n", what, nfd_result_string(r));
    std::exit(1);
}

// Multiply-adds per point: the weights of every layer.
double weights_per_point(const nfd_asset_info& info) {
    double in = 3.0 + 6.0 * info.num_frequencies, macs = 0;
    for (uint32_t l = 0; l < info.num_layers; ++l) {
        macs += in * info.layer_widths[l];
        in = info.layer_widths[l];
    }
    return macs;
}

struct Timing {
    double wall_s = 1e30, cpu_s = 1e30, first_s = 0;
};

// One evaluation of `n` points: values, or values and gradients.
void evaluate(nfd_context* ctx, const nfd_asset* asset, const float* points, size_t n,
              float* values, float* gradients, const char* what) {
    check(gradients ? nfd_asset_evaluate_gradient(ctx, asset, points, n, values, gradients)
                    : nfd_asset_evaluate(ctx, asset, points, n, values),
          what);
}

Timing time_evaluate(nfd_device_kind kind, uint32_t threads, const nfd_asset* asset,
                     const std::vector<float>& points, int repeat, bool with_gradients) {
    nfd_context_options co{};
    co.struct_size = sizeof co;
    co.device = kind;
    co.cpu_threads = threads;
    nfd_context* ctx = nullptr;
    check(nfd_context_create(&co, &ctx), "context");
    const size_t n = points.size() / 3;
    std::vector<float> values(n), gradients(with_gradients ? 3 * n : 0);
    float* g = with_gradients ? gradients.data() : nullptr;
    Timing best;
    const auto t_first = Clock::now();
    evaluate(ctx, asset, points.data(), std::min<size_t>(n, 4096), values.data(), g,
             "warm-up");  // pipelines, network upload
    best.first_s = std::chrono::duration<double>(Clock::now() - t_first).count();
    for (int k = 0; k < repeat; ++k) {
        const auto t0 = Clock::now();
        const std::clock_t c0 = std::clock();
        evaluate(ctx, asset, points.data(), n, values.data(), g, "evaluate");
        best.cpu_s = std::min(best.cpu_s, double(std::clock() - c0) / CLOCKS_PER_SEC);
        best.wall_s = std::min(best.wall_s, std::chrono::duration<double>(Clock::now() - t0).count());
    }
    nfd_context_destroy(ctx);
    return best;
}

}  // namespace

int main(int argc, char** argv) {
    size_t count = size_t(1) << 20;
    int repeat = 3;
    bool vulkan = false, gradients = false;
    std::vector<const char*> files;
    for (int i = 1; i < argc; ++i) {
        if (!std::strcmp(argv[i], "--points") && i + 1 < argc) count = std::strtoull(argv[++i], nullptr, 10);
        else if (!std::strcmp(argv[i], "--repeat") && i + 1 < argc) repeat = std::atoi(argv[++i]);
        else if (!std::strcmp(argv[i], "--vulkan")) vulkan = true;
        else if (!std::strcmp(argv[i], "--gradients")) gradients = true;
        else files.push_back(argv[i]);
    }
    if (files.empty() || count == 0 || repeat < 1) {
        std::fprintf(stderr,
                     "usage: field_eval [--points N] [--repeat K] [--vulkan] [--gradients] "
                     "FILE.nfc...\n");
        return 2;
    }
    const uint32_t cores = std::max(1u, std::thread::hardware_concurrency());
    std::printf("| file | width | path | threads | Mpoints/s | GFLOP/s | wall ms | CPU ms | first call ms |\n");
    std::printf("|---|---:|---|---:|---:|---:|---:|---:|---:|\n");
    for (const char* path : files) {
        const std::vector<unsigned char> bytes = read_file(path);
        nfd_asset* asset = nullptr;
        check(nfd_asset_create(bytes.data(), bytes.size(), &asset), path);
        nfd_asset_info info{};
        check(nfd_asset_get_info(asset, &info), path);
        // Uniform in the unit cube, in the original frame.
        std::mt19937 rng(1);
        std::uniform_real_distribution<float> u(-1.0f, 1.0f);
        std::vector<float> points(3 * count);
        for (size_t i = 0; i < points.size(); ++i) points[i] = u(rng) * info.scale + info.center[i % 3];
        const double flops = (gradients ? 4.0 : 2.0) * weights_per_point(info) * double(count);
        const char* name = std::strrchr(path, '/') ? std::strrchr(path, '/') + 1 : path;
        struct Run {
            nfd_device_kind kind;
            uint32_t threads;
            const char* label;
        };
        std::vector<Run> runs = {{NFD_DEVICE_CPU, 1, "C++"}, {NFD_DEVICE_CPU, cores, "C++"}};
        if (vulkan) runs.push_back({NFD_DEVICE_VULKAN, 0, "Vulkan"});
        for (const Run& r : runs) {
            const Timing t = time_evaluate(r.kind, r.threads, asset, points, repeat, gradients);
            std::printf("| %s | %u | %s | %u | %.2f | %.1f | %.1f | %.1f | %.1f |\n", name,
                        info.layer_widths[0], r.label, r.kind == NFD_DEVICE_CPU ? r.threads : 0,
                        double(count) / t.wall_s * 1e-6, flops / t.wall_s * 1e-9, t.wall_s * 1e3,
                        t.cpu_s * 1e3, t.first_s * 1e3);
        }
        nfd_asset_destroy(asset);
    }
    return 0;
}
