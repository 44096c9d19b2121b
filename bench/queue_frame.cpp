// The caller's side of the asynchronous queue: a 60 Hz frame loop on the main thread that receives
// assets through nfd_stream, submits each the frame its geometry is ready, polls every job each
// frame and takes every level's mesh as it is delivered, timing every call into libnfdecode but
// nfd_mesh_destroy (timed apart: an engine frees meshes where it likes). Prints two markdown
// tables: the frame thread's time inside libnfdecode per frame (max, p99, mean; wall and CPU
// time; the largest per kind of call), and per asset the time from its first byte to its geometry,
// its first level's mesh and its final mesh.
//
//     build/bench/queue_frame --device vulkan --resolution 256 --levels 32,64,128,256 \
//         bench/out/nfc/*.nfc
//
// With --submit-stream each file's job is submitted before its first byte
// (nfd_queue_submit_stream, skip_colour: it starts on the geometry, as the asset that
// nfd_stream_take_asset gives) and every frame feeds the job (nfd_job_feed).
//
// Arrival: each file's bytes arrive at --bandwidth (default 256 KB/s; B/s, KB/s, MB/s with
// 1 KB = 1024 B), all files at once from the first frame, as over parallel connections. Each
// frame feeds every stream the bytes that arrived since the last.
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
    nfd_stream* stream = nullptr;  // until the whole file is fed (without --submit-stream)
    size_t fed = 0;
    bool feeding = true;           // bytes still to come
    nfd_job* job = nullptr;
    uint32_t taken_resolution = 0;  // of the newest mesh taken
    bool collected = false;
    double geometry_s = 0, first_level_s = 0, final_s = 0;  // since the first byte
    uint32_t first_level_resolution = 0;
};

// The kinds of call the frame thread makes.
enum Kind { kFeed, kSubmit, kPoll, kTake, kKinds };
const char* const kKindNames[kKinds] = {"feed", "submit", "poll", "take"};

// Sums the time spent inside libnfdecode calls of one frame: wall time, and the thread's CPU
// time (which excludes time the thread was descheduled, whether preempted by other threads of a
// loaded machine or asleep waiting). Voluntary context switches inside a call count the calls
// that slept: waited on a lock, which the queue's caller-side calls should never do for long.
struct FrameTimer {
    double frame_seconds = 0, frame_cpu_seconds = 0;
    double kind_seconds[kKinds] = {};
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
    auto operator()(Kind kind, Fn&& fn) {
        const long switches = voluntary_switches();
        const double cpu = thread_cpu();
        const auto t0 = Clock::now();
        auto r = fn();
        const double s = std::chrono::duration<double>(Clock::now() - t0).count();
        frame_cpu_seconds += thread_cpu() - cpu;
        sleeps += voluntary_switches() - switches;
        frame_seconds += s;
        kind_seconds[kind] += s;
        return r;
    }
};

// "256KB/s", "2 MB/s", "100B/s", "4096": bytes per second (1 KB = 1024 B); 0 if unreadable.
double parse_bandwidth(const char* text) {
    char* end = nullptr;
    const double v = std::strtod(text, &end);
    std::string unit(end);
    unit.erase(std::remove(unit.begin(), unit.end(), ' '), unit.end());
    if (unit.empty() || unit == "B/s") return v;
    if (unit == "KB/s") return v * 1024;
    if (unit == "MB/s") return v * 1024 * 1024;
    return 0;
}

// "300MB", "1GB", "1048576": bytes (1 KB = 1024 B); 0 if unreadable.
uint64_t parse_bytes(const char* text) {
    char* end = nullptr;
    const double v = std::strtod(text, &end);
    const std::string unit(end);
    const double scale = unit.empty() || unit == "B" ? 1
                         : unit == "KB"             ? 1024.0
                         : unit == "MB"             ? 1024.0 * 1024
                         : unit == "GB"             ? 1024.0 * 1024 * 1024
                                                    : 0;
    return uint64_t(v * scale);
}

// "32,64,128,256": the ladder mask of those resolutions in `resolution`'s ladder; 0 if one is not
// on it (an empty list: 0, the final level only).
uint32_t parse_levels(const char* text, uint32_t resolution) {
    uint32_t ladder[NFD_MAX_LADDER_LEVELS], count = 0;
    if (nfd_extraction_ladder(resolution, ladder, NFD_MAX_LADDER_LEVELS, &count) != NFD_SUCCESS)
        return 0;
    uint32_t mask = 0;
    for (const char* p = text; *p;) {
        char* end = nullptr;
        const unsigned long r = std::strtoul(p, &end, 10);
        const uint32_t* at = std::find(ladder, ladder + count, uint32_t(r));
        if (end == p || at == ladder + count) return 0;
        mask |= 1u << (at - ladder);
        p = *end == ',' ? end + 1 : end;
    }
    return mask;
}

int usage() {
    std::fprintf(stderr,
                 "usage: queue_frame [--device cpu|vulkan] [--resolution N] [--workers N]\n"
                 "                   [--cpu-threads N] [--budget BYTES[KB|MB|GB]]\n"
                 "                   [--bandwidth N[B/s|KB/s|MB/s]] [--levels R,R,...]\n"
                 "                   [--submit-stream]\n"
                 "                   file.nfc...\n");
    return 2;
}

struct Summary {
    double max, p99, mean;
};
Summary summarise(std::vector<double> v) {
    std::sort(v.begin(), v.end());
    double sum = 0;
    for (double f : v) sum += f;
    return Summary{v.back(), v[std::min(v.size() - 1, size_t(0.99 * double(v.size())))],
                   sum / double(v.size())};
}

}  // namespace

int main(int argc, char** argv) {
    nfd_device_kind device = NFD_DEVICE_AUTO;
    uint32_t resolution = 256, workers = 1, cpu_threads = 0;
    uint64_t budget = 0;
    double bandwidth = 256.0 * 1024.0;  // bytes per second per file
    const char* levels = "";
    bool submit_stream = false;
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
        } else if (a == "--budget" && (v = value())) {
            if (!(budget = parse_bytes(v))) return usage();
        } else if (a == "--bandwidth" && (v = value())) {
            if ((bandwidth = parse_bandwidth(v)) <= 0) return usage();
        } else if (a == "--levels" && (v = value())) {
            levels = v;
        } else if (a == "--submit-stream") {
            submit_stream = true;
        } else if (a.rfind("--", 0) == 0) {
            return usage();
        } else {
            std::ifstream in(a, std::ios::binary);
            if (!in) {
                std::fprintf(stderr, "cannot read %s\n", a.c_str());
                return 1;
            }
            Source s;
            s.path = a;
            s.bytes.assign(std::istreambuf_iterator<char>(in), {});
            sources.push_back(std::move(s));
        }
    }
    if (sources.empty()) return usage();
    const uint32_t mesh_levels = *levels ? parse_levels(levels, resolution) : 0;
    if (*levels && !mesh_levels) {
        std::fprintf(stderr, "--levels %s: not on the ladder of %u\n", levels, resolution);
        return 2;
    }

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
    qo.host_budget_bytes = budget;
    nfd_queue* queue = nullptr;
    if ((r = nfd_queue_create(ctx, &qo, &queue)) != NFD_SUCCESS) {
        std::fprintf(stderr, "queue: %s\n", nfd_result_string(r));
        return 1;
    }
    nfd_mesh_options mo = {};
    mo.struct_size = sizeof mo;
    mo.resolution = resolution;
    nfd_job_options jo = {};
    jo.struct_size = sizeof jo;
    jo.mesh_levels = mesh_levels;
    for (Source& s : sources) {  // before the first frame: no byte has arrived yet
        if ((r = nfd_stream_create(nullptr, &s.stream)) != NFD_SUCCESS) {
            std::fprintf(stderr, "stream: %s\n", nfd_result_string(r));
            return 1;
        }
        if (!submit_stream) continue;
        nfd_mesh_options geometry = mo;
        geometry.skip_colour = 1;
        if ((r = nfd_queue_submit_stream(queue, s.stream, &geometry, &jo, &s.job)) != NFD_SUCCESS) {
            std::fprintf(stderr, "submit: %s\n", nfd_result_string(r));
            return 1;
        }
        s.stream = nullptr;  // the job's now
    }

    const auto frame = std::chrono::microseconds(16667);
    const auto start = Clock::now();
    auto since_start = [&] { return std::chrono::duration<double>(Clock::now() - start).count(); };
    std::vector<double> frames, frames_cpu;  // seconds inside libnfdecode, per frame
    double kind_max[kKinds] = {};            // the largest per frame, per kind of call
    long sleeps = 0;
    double all_done = 0, mesh_destroy_max = 0;
    size_t collected = 0, triangles = 0, failures = 0, meshes = 0;
    for (auto next = start; collected < sources.size(); next += frame) {
        std::this_thread::sleep_until(next);
        const double now = since_start();
        FrameTimer timed;
        for (Source& s : sources) {
            if (s.feeding && submit_stream) {
                const size_t arrived = std::min(s.bytes.size(), size_t(bandwidth * now));
                nfd_stream_progress p{};
                r = timed(kFeed, [&] {
                    return nfd_job_feed(s.job, s.bytes.data() + s.fed, arrived - s.fed, &p);
                });
                s.fed = arrived;
                if (!s.geometry_s && (p.flags & NFD_STREAM_GEOMETRY_READY)) s.geometry_s = since_start();
                if (r == NFD_SUCCESS && s.fed == s.bytes.size())
                    r = timed(kFeed, [&] { return nfd_job_finish_input(s.job); });
                if (r != NFD_SUCCESS) {
                    std::fprintf(stderr, "%s: %s\n", s.path.c_str(), nfd_result_string(r));
                    return 1;
                }
                s.feeding = s.fed < s.bytes.size();
            } else if (s.stream) {
                const size_t arrived = std::min(s.bytes.size(), size_t(bandwidth * now));
                nfd_stream_progress p{};
                r = timed(kFeed, [&] {
                    return nfd_stream_feed(s.stream, s.bytes.data() + s.fed, arrived - s.fed, &p);
                });
                s.fed = arrived;
                if (r == NFD_SUCCESS && !s.job && (p.flags & NFD_STREAM_GEOMETRY_READY)) {
                    nfd_asset* asset = nullptr;
                    r = timed(kFeed, [&] { return nfd_stream_take_asset(s.stream, &asset); });
                    if (r == NFD_SUCCESS)
                        r = timed(kSubmit, [&] {
                            return nfd_queue_submit(queue, asset, &mo, &jo, &s.job);
                        });
                    timed(kSubmit, [&] { nfd_asset_destroy(asset); return 0; });
                    s.geometry_s = since_start();
                }
                if (r == NFD_SUCCESS && s.fed == s.bytes.size())
                    r = timed(kFeed, [&] { return nfd_stream_finish(s.stream); });
                if (r != NFD_SUCCESS) {
                    std::fprintf(stderr, "%s: %s\n", s.path.c_str(), nfd_result_string(r));
                    return 1;
                }
                if (s.fed == s.bytes.size()) {
                    timed(kFeed, [&] { nfd_stream_destroy(s.stream); return 0; });
                    s.stream = nullptr;
                }
            }
            if (!s.job || s.collected) continue;
            const nfd_job_status st = timed(kPoll, [&] { return nfd_job_poll(s.job); });
            const bool final = st == NFD_JOB_DONE || st == NFD_JOB_FAILED || st == NFD_JOB_CANCELLED;
            nfd_job_progress p = {};
            p.struct_size = sizeof p;
            timed(kPoll, [&] { return nfd_job_get_progress(s.job, &p); });
            if (!final && p.newest_mesh_resolution == s.taken_resolution) continue;
            nfd_mesh* mesh = nullptr;
            r = timed(kTake, [&] { return nfd_job_take_mesh(s.job, &mesh); });
            if (r != NFD_SUCCESS) ++failures;
            if (mesh) {
                nfd_mesh_data d{};
                timed(kTake, [&] { return nfd_mesh_get_data(mesh, &d); });
                timed(kTake, [&] { return nfd_job_get_progress(s.job, &p); });
                s.taken_resolution = p.taken_mesh_resolution;
                if (!s.first_level_s) {
                    s.first_level_s = since_start();
                    s.first_level_resolution = p.taken_mesh_resolution;
                }
                ++meshes;
                if (final) triangles += d.triangle_count;
            }
            // A renderer would upload the mesh here; this loop only releases it. Freeing a mesh
            // of tens of MB unmaps its pages (milliseconds, longer while workers fault pages in):
            // timed apart, off the frame's libnfdecode time.
            const auto t0 = Clock::now();
            nfd_mesh_destroy(mesh);
            mesh_destroy_max = std::max(
                mesh_destroy_max, std::chrono::duration<double>(Clock::now() - t0).count());
            if (!final) continue;
            if (!s.final_s) s.final_s = since_start();
            if (s.feeding && submit_stream) continue;  // the job holds the stream: destroy it later
            timed(kPoll, [&] { nfd_job_destroy(s.job); return 0; });
            s.collected = true;
            ++collected;
        }
        frames.push_back(timed.frame_seconds);
        frames_cpu.push_back(timed.frame_cpu_seconds);
        for (int k = 0; k < kKinds; ++k) kind_max[k] = std::max(kind_max[k], timed.kind_seconds[k]);
        sleeps += timed.sleeps;
        all_done = since_start();
    }
    nfd_queue_stats st{};
    nfd_queue_get_stats(queue, &st);
    nfd_queue_destroy(queue);

    const Summary wall = summarise(frames), cpu = summarise(frames_cpu);
    char budget_text[32] = "-";
    if (budget) std::snprintf(budget_text, sizeof budget_text, "%.0f MiB", budget / 1048576.0);
    std::printf("| device | res | levels | files | KB/s | workers | budget | frames "
                "| ms/frame max / p99 / mean | CPU ms/frame max / p99 / mean "
                "| max ms/frame feed / submit / poll / take | calls that slept "
                "| meshes | nfd_mesh_destroy max ms | all done s | peak reserved MiB |\n");
    std::printf("|---|---:|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n");
    std::printf("| %s | %u | %s | %zu | %.0f | %u | %s | %zu | %.3f / %.3f / %.4f "
                "| %.3f / %.3f / %.4f | %.3f / %.3f / %.3f / %.3f | %ld | %zu | %.2f | %.2f "
                "| %.0f |\n",
                nfd_context_device_name(ctx), resolution, *levels ? levels : "final",
                sources.size(), bandwidth / 1024, workers, budget_text, frames.size(),
                wall.max * 1e3, wall.p99 * 1e3, wall.mean * 1e3, cpu.max * 1e3, cpu.p99 * 1e3,
                cpu.mean * 1e3, kind_max[kFeed] * 1e3, kind_max[kSubmit] * 1e3,
                kind_max[kPoll] * 1e3, kind_max[kTake] * 1e3, sleeps, meshes,
                mesh_destroy_max * 1e3, all_done,
                double(std::max(st.peak_reserved_host_bytes, st.peak_reserved_device_bytes)) /
                    (1 << 20));
    std::printf("\n| asset | bytes | geometry s | first level s (cells) | final s |\n"
                "|---|---:|---:|---:|---:|\n");
    for (const Source& s : sources) {
        const size_t slash = s.path.find_last_of('/');
        std::printf("| %s | %zu | %.3f | %.3f (%u) | %.3f |\n",
                    s.path.substr(slash == std::string::npos ? 0 : slash + 1).c_str(),
                    s.bytes.size(), s.geometry_s, s.first_level_s, s.first_level_resolution,
                    s.final_s);
    }
    std::printf("\ntriangles of the final meshes: %zu\n", triangles);
    nfd_context_destroy(ctx);
    return failures ? 1 : 0;
}
