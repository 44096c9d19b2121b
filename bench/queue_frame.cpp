// The caller's side of the asynchronous queue: a 60 Hz frame loop on the main thread that receives
// assets, submits them, polls every job each frame and collects the meshes, timing every call into
// libnfdecode but nfd_mesh_destroy (timed apart). Prints a markdown table: time inside libnfdecode
// per frame (max, p99, mean), the slowest single call, and the time until every mesh was
// collected.
//
//     build/bench/queue_frame --device vulkan --resolution 256 bench/out/nfc/*.nfc
//
// Arrival: each file's bytes arrive at --rate-kbps (default 256 KB/s), all files at once, as
// over parallel connections. Today a file is parsed whole (nfd_asset_create) in the frame its last
// byte arrives; with nfd_stream the frame feeds what arrived (Source::arrived_this_frame) instead.
#include <nfdecode/nfdecode.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <iterator>
#include <string>
#include <thread>
#include <vector>

#include <sys/resource.h>
#include <time.h>

namespace {

using Clock = std::chrono::steady_clock;

struct Source {
    std::string path;
    std::vector<unsigned char> bytes;
    size_t received = 0;  // bytes arrived so far
    nfd_job* job = nullptr;
    bool collected = false;
};

// Sums the time spent inside libnfdecode calls of one frame.
// Sums the time spent inside libnfdecode calls of one frame: wall time, and the thread's CPU
// time (which excludes time the thread was descheduled, whether preempted by other threads of a
// loaded machine or asleep waiting). Voluntary context switches inside a call count the calls
// that slept: waited on a lock, which the queue's caller-side calls should never do for long.
struct FrameTimer {
    double frame_seconds = 0, frame_cpu_seconds = 0, slowest_call = 0;
    const char* slowest_name = "";
    long sleeps = 0;
    static double thread_cpu() {
        timespec t;
        clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
        return double(t.tv_sec) + 1e-9 * double(t.tv_nsec);
    }
    static long voluntary_switches() {
        rusage u;
        getrusage(RUSAGE_THREAD, &u);
        return u.ru_nvcsw;
    }
    template <class Fn>
    auto operator()(const char* name, Fn&& fn) {
        const long switches = voluntary_switches();
        const double cpu = thread_cpu();
        const auto t0 = Clock::now();
        auto r = fn();
        const double s = std::chrono::duration<double>(Clock::now() - t0).count();
        frame_cpu_seconds += thread_cpu() - cpu;
        sleeps += voluntary_switches() - switches;
        frame_seconds += s;
        if (s > slowest_call) slowest_call = s, slowest_name = name;
        return r;
    }
};

int usage() {
    std::fprintf(stderr,
                 "usage: queue_frame [--device cpu|vulkan] [--resolution N] [--workers N]\n"
                 "                   [--budget-mb N] [--rate-kbps N] [--cpu-threads N]\n"
                 "                   file.nfc...\n");
    return 2;
}

}  // namespace

int main(int argc, char** argv) {
    nfd_device_kind device = NFD_DEVICE_AUTO;
    uint32_t resolution = 256, workers = 1, cpu_threads = 0;
    uint64_t budget_mb = 0;
    double rate = 256.0 * 1024.0;  // bytes per second per file
    std::vector<Source> sources;
    for (int i = 1; i < argc; ++i) {
        const std::string a = argv[i];
        auto value = [&]() -> const char* { return i + 1 < argc ? argv[++i] : nullptr; };
        const char* v = nullptr;
        if (a == "--device" && (v = value())) {
            device = std::strcmp(v, "cpu") == 0 ? NFD_DEVICE_CPU : NFD_DEVICE_VULKAN;
        } else if (a == "--resolution" && (v = value())) {
            resolution = uint32_t(std::atoi(v));
        } else if (a == "--workers" && (v = value())) {
            workers = uint32_t(std::atoi(v));
        } else if (a == "--cpu-threads" && (v = value())) {
            cpu_threads = uint32_t(std::atoi(v));
        } else if (a == "--budget-mb" && (v = value())) {
            budget_mb = uint64_t(std::atoll(v));
        } else if (a == "--rate-kbps" && (v = value())) {
            rate = std::atof(v) * 1024.0;
        } else if (a.rfind("--", 0) == 0) {
            return usage();
        } else {
            std::ifstream in(a, std::ios::binary);
            if (!in) {
                std::fprintf(stderr, "cannot read %s\n", a.c_str());
                return 1;
            }
            sources.push_back({a, {std::istreambuf_iterator<char>(in), {}}});
        }
    }
    if (sources.empty()) return usage();

    nfd_context_options co = {};
    co.struct_size = sizeof co;
    co.device = device;
    co.cpu_threads = cpu_threads;
    nfd_context* ctx = nullptr;
    nfd_result r = nfd_context_create(&co, &ctx);
    if (r != NFD_SUCCESS) {
        std::fprintf(stderr, "context: %s\n", nfd_result_string(r));
        return 1;
    }
    nfd_queue_options qo = {};
    qo.struct_size = sizeof qo;
    qo.worker_threads = workers;
    qo.host_budget_bytes = budget_mb << 20;
    qo.device_budget_bytes = budget_mb << 20;
    nfd_queue* queue = nullptr;
    if ((r = nfd_queue_create(ctx, &qo, &queue)) != NFD_SUCCESS) {
        std::fprintf(stderr, "queue: %s\n", nfd_result_string(r));
        return 1;
    }
    nfd_mesh_options mo = {};
    mo.struct_size = sizeof mo;
    mo.resolution = resolution;

    const auto frame = std::chrono::microseconds(16667);
    const auto start = Clock::now();
    std::vector<double> frames, frames_cpu;  // seconds inside libnfdecode, per frame
    long sleeps = 0;
    double slowest_call = 0, all_done = 0;
    const char* slowest_name = "";
    double mesh_destroy_max = 0;
    size_t collected = 0, triangles = 0, failures = 0;
    for (auto next = start; collected < sources.size(); next += frame) {
        std::this_thread::sleep_until(next);
        const double now = std::chrono::duration<double>(Clock::now() - start).count();
        FrameTimer timed;
        for (Source& s : sources) {
            if (!s.job) {
                const size_t arrived = std::min(s.bytes.size(), size_t(rate * now));
                // With nfd_stream: feed bytes [s.received, arrived) here, submit when it yields.
                s.received = arrived;
                if (s.received < s.bytes.size()) continue;
                nfd_asset* asset = nullptr;
                r = timed("nfd_asset_create", [&] {
                    return nfd_asset_create(s.bytes.data(), s.bytes.size(), &asset);
                });
                if (r == NFD_SUCCESS)
                    r = timed("nfd_queue_submit", [&] {
                        return nfd_queue_submit(queue, asset, &mo, nullptr, &s.job);
                    });
                timed("nfd_asset_destroy", [&] { nfd_asset_destroy(asset); return 0; });
                if (r != NFD_SUCCESS) {
                    std::fprintf(stderr, "%s: %s\n", s.path.c_str(), nfd_result_string(r));
                    return 1;
                }
                continue;
            }
            if (s.collected) continue;
            const nfd_job_status st = timed("nfd_job_poll", [&] { return nfd_job_poll(s.job); });
            if (st != NFD_JOB_DONE && st != NFD_JOB_FAILED && st != NFD_JOB_CANCELLED) continue;
            nfd_mesh* mesh = nullptr;
            r = timed("nfd_job_take_mesh", [&] { return nfd_job_take_mesh(s.job, &mesh); });
            nfd_mesh_data d{};
            if (r == NFD_SUCCESS)
                timed("nfd_mesh_get_data", [&] { return nfd_mesh_get_data(mesh, &d); });
            else
                ++failures;
            triangles += d.triangle_count;
            // A renderer would upload the mesh here; this loop only releases it.
            // Freeing a mesh of tens of MB unmaps its pages (milliseconds, longer while workers
            // fault pages in): an engine frees meshes where it likes, so it is timed apart.
            const auto t0 = Clock::now();
            nfd_mesh_destroy(mesh);
            mesh_destroy_max = std::max(
                mesh_destroy_max, std::chrono::duration<double>(Clock::now() - t0).count());
            timed("nfd_job_destroy", [&] { nfd_job_destroy(s.job); return 0; });
            s.collected = true;
            ++collected;
        }
        frames.push_back(timed.frame_seconds);
        frames_cpu.push_back(timed.frame_cpu_seconds);
        sleeps += timed.sleeps;
        if (timed.slowest_call > slowest_call)
            slowest_call = timed.slowest_call, slowest_name = timed.slowest_name;
        all_done = std::chrono::duration<double>(Clock::now() - start).count();
    }
    nfd_queue_stats st{};
    nfd_queue_get_stats(queue, &st);
    nfd_queue_destroy(queue);

    struct Summary {
        double max, p99, mean;
    };
    auto summarise = [](std::vector<double> v) {
        std::sort(v.begin(), v.end());
        double sum = 0;
        for (double f : v) sum += f;
        return Summary{v.back(), v[std::min(v.size() - 1, size_t(0.99 * double(v.size())))],
                       sum / double(v.size())};
    };
    const Summary wall = summarise(frames), cpu = summarise(frames_cpu);
    std::printf("| device | res | files | workers | budget MB | frames | ms/frame max / p99 / mean "
                "| CPU ms/frame max / p99 / mean | slowest call ms | calls that slept "
                "| nfd_mesh_destroy max ms | all done s | triangles | peak reserved MB |\n");
    std::printf("|---|---:|---:|---:|---:|---:|---:|---:|---|---:|---:|---:|---:|---:|\n");
    std::printf("| %s | %u | %zu | %u | %s | %zu | %.3f / %.3f / %.4f | %.3f / %.3f / %.4f "
                "| %.3f %s | %ld | %.2f | %.2f | %zu | %.0f |\n",
                nfd_context_device_name(ctx), resolution, sources.size(), workers,
                budget_mb ? std::to_string(budget_mb).c_str() : "-", frames.size(), wall.max * 1e3,
                wall.p99 * 1e3, wall.mean * 1e3, cpu.max * 1e3, cpu.p99 * 1e3, cpu.mean * 1e3,
                slowest_call * 1e3, slowest_name, sleeps, mesh_destroy_max * 1e3, all_done,
                triangles,
                double(std::max(st.peak_reserved_host_bytes, st.peak_reserved_device_bytes)) /
                    (1 << 20));
    nfd_context_destroy(ctx);
    return failures ? 1 : 0;
}
