// nfc-decode: .nfc -> .glb / .ply (mesh or points) / .vdb (sparse grid) over the public libnfdecode
// API only.
//
//   nfc-decode IN.nfc -o OUT.{glb,ply,vdb} [--resolution N] [--points N] [--no-colour]
//              [--sample-band] [--device auto|vulkan|cpu] [--stream-chunk N [--bandwidth R]]
//              [--threads N] [--stats] [--pipeline-cache FILE]
//   nfc-decode IN.nfc -o OUT.{glb,ply} --levels R1,R2,... [--write-levels] [--stats[=json]]
//
// Errors are one line on stderr ("nfc-decode: error: ...") and a non-zero exit status: 2 for a
// bad command line, 1 for anything that failed while decoding.
#include <nfdecode/nfdecode.h>

#include "../common/cli_values.h"
#include "../common/pipeline_cache_file.h"

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <ctime>
#include <memory>
#include <string>
#include <thread>
#include <vector>

namespace {

const char kUsage[] =
    "usage: nfc-decode IN.nfc -o OUT.{glb,ply,vdb} [--resolution N] [--points N] [--no-colour]\n"
    "                  [--sample-band] [--device auto|vulkan|cpu] [--stream-chunk N [--bandwidth R]]\n"
    "                  [--threads N] [--stats] [--pipeline-cache FILE]\n"
    "  OUT             .glb or .ply: the surface mesh; .vdb: the distance on a narrow band\n"
    "                  around it (OpenVDB)\n"
    "  --resolution N  grid cells per axis over the unit cube (8..1024, default 256)\n"
    "  --points N      write N points sampled uniformly on the surface (PLY) instead of the mesh\n"
    "  --no-colour     geometry only (a file with colour otherwise writes it: PLY red/green/blue,\n"
    "                  glTF COLOR_0, a VDB colour grid)\n"
    "  --sample-band   sample the band around the surface, not only the cells it crosses (UDF:\n"
    "                  can carry triangles): ~2-2.5x the field evaluations, and an SDF's small\n"
    "                  voids are found too (nfd_mesh_options.sample_band; .vdb always does, and\n"
    "                  Vulkan does but for a UDF's finest level)\n"
    "  --device D      auto (a GPU, else the CPU path; default), vulkan (lavapipe too), or cpu\n"
    "  --threads N     threads of the CPU path and of a Vulkan decode's host work (1..1024;\n"
    "                  default: one per core); the output does not depend on it\n"
    "  --stream-chunk N\n"
    "                  feed the file to nfd_stream N bytes at a time, never holding it whole;\n"
    "                  meshing starts from the asset the stream yields\n"
    "  --bandwidth R   with --stream-chunk: pace the pieces as if the file arrived at R, a\n"
    "                  positive number then B/s, KB/s or MB/s (1 KB = 1024 B), e.g. 256KB/s\n"
    "  --stats         print sizes, per-stage timings and counts\n"
    "  --pipeline-cache FILE\n"
    "                  start the Vulkan device's pipeline cache from FILE when it was saved on\n"
    "                  this device and is intact (else ignored), and save the cache there after\n"
    "                  the decode (e.g. ~/.cache/nfc/pipelines.bin)\n"
    "  --levels LIST   decode progressively through the ladder levels LIST (ascending, e.g.\n"
    "                  32,64,128,256: levels of the last one's ladder), write the last\n"
    "  --write-levels  with --levels, also write each level as OUT.<resolution>.<ext>\n"
    "  --stats=json    with --levels, one JSON object per level, then a summary line\n";

struct Failure {
    int status;
    std::string message;
};

[[noreturn]] void fail(int status, const std::string& message) { throw Failure{status, message}; }

void check(nfd_result r, const std::string& what) {
    if (r != NFD_SUCCESS) fail(1, what + ": " + nfd_result_string(r));
}

struct Options {
    std::string input, output;
    uint32_t resolution = 0;
    size_t points = 0;
    bool no_colour = false;
    bool sample_band = false;
    nfd_device_kind device = NFD_DEVICE_AUTO;
    uint32_t threads = 0;     // 0: one per core (nfd_context_options.cpu_threads)
    size_t stream_chunk = 0;  // 0: read the whole file, then nfd_asset_create
    double bandwidth = 0;     // bytes per second; 0: as fast as the file reads
    std::string pipeline_cache;  // empty: none kept between runs
    bool stats = false;
    // Progressive decoding (decode_progressive).
    std::vector<uint32_t> levels;  // ascending resolutions of the last one's ladder
    bool write_levels = false, stats_json = false;
};

unsigned long long parse_count(const char* flag, const char* text, unsigned long long min,
                               unsigned long long max) {
    char* end = nullptr;
    errno = 0;
    const unsigned long long v = std::strtoull(text, &end, 10);
    if (!*text || *end || errno || text[0] == '-' || v < min || v > max)
        fail(2, std::string(flag) + " expects an integer in " + std::to_string(min) + ".." +
                    std::to_string(max) + ", got '" + text + "'");
    return v;
}

double parse_bandwidth(const char* text) {
    std::string error;
    const double v = nfc_cli::parse_bandwidth(text, &error);
    if (!error.empty()) fail(2, error);
    return v;
}

bool ends_with(const std::string& s, const char* suffix) {
    const size_t n = std::strlen(suffix);
    if (s.size() < n) return false;
    for (size_t i = 0; i < n; ++i)
        if (std::tolower(static_cast<unsigned char>(s[s.size() - n + i])) != suffix[i]) return false;
    return true;
}

std::vector<uint32_t> parse_levels(const char* text) {
    std::string error;
    std::vector<uint32_t> levels = nfc_cli::parse_levels(text, &error);
    if (!error.empty()) fail(2, error);
    return levels;
}

void check_progressive_options(Options* o) {
    if (o->levels.empty()) {
        if (o->write_levels || o->stats_json) fail(2, "--write-levels and --stats=json need --levels");
        return;
    }
    if (o->resolution && o->resolution != o->levels.back())
        fail(2, "--resolution differs from the last of --levels");
    if (o->points || ends_with(o->output, ".vdb"))
        fail(2, "--levels writes meshes: no --points, and the output must be .glb or .ply");
    o->resolution = o->levels.back();
}

Options parse_args(int argc, char** argv) {
    Options o;
    for (int i = 1; i < argc; ++i) {
        const std::string arg = argv[i];
        auto value = [&]() -> const char* {
            if (i + 1 >= argc) fail(2, arg + " needs a value");
            return argv[++i];
        };
        if (arg == "-h" || arg == "--help") {
            std::fputs(kUsage, stdout);
            std::exit(0);
        } else if (arg == "-o") {
            o.output = value();
        } else if (arg == "--resolution") {
            o.resolution = uint32_t(
                parse_count("--resolution", value(), NFD_MIN_RESOLUTION, NFD_MAX_RESOLUTION));
        } else if (arg == "--points") {
            o.points = size_t(parse_count("--points", value(), 1, 100000000ull));
        } else if (arg == "--sample-band") {
            o.sample_band = true;
        } else if (arg == "--no-colour" || arg == "--no-color") {
            o.no_colour = true;
        } else if (arg == "--device") {
            const std::string d = value();
            if (d == "auto") o.device = NFD_DEVICE_AUTO;
            else if (d == "vulkan") o.device = NFD_DEVICE_VULKAN;
            else if (d == "cpu") o.device = NFD_DEVICE_CPU;
            else fail(2, "--device expects auto, vulkan or cpu, got '" + d + "'");
        } else if (arg == "--threads") {
            o.threads = uint32_t(parse_count("--threads", value(), 1, 1024));
        } else if (arg == "--stream-chunk") {
            o.stream_chunk = size_t(parse_count("--stream-chunk", value(), 1, NFD_MAX_FILE_SIZE));
        } else if (arg == "--bandwidth") {
            o.bandwidth = parse_bandwidth(value());
        } else if (arg == "--pipeline-cache") {
            o.pipeline_cache = value();
        } else if (arg == "--stats") {
            o.stats = true;
        } else if (arg == "--stats=json") {
            o.stats_json = true;
        } else if (arg == "--levels") {
            o.levels = parse_levels(value());
        } else if (arg == "--write-levels") {
            o.write_levels = true;
        } else if (!arg.empty() && arg[0] == '-') {
            fail(2, "unknown option '" + arg + "' (see --help)");
        } else if (o.input.empty()) {
            o.input = arg;
        } else {
            fail(2, "more than one input file ('" + o.input + "', '" + arg + "')");
        }
    }
    if (o.input.empty()) fail(2, "no input file (see --help)");
    if (o.output.empty()) fail(2, "no output file: use -o OUT.glb, OUT.ply or OUT.vdb");
    if (!ends_with(o.output, ".glb") && !ends_with(o.output, ".ply") &&
        !ends_with(o.output, ".vdb"))
        fail(2, "output must end in .glb or .ply (mesh) or .vdb (grid): '" + o.output + "'");
    if (o.points && !ends_with(o.output, ".ply"))
        fail(2, "--points writes a point cloud: the output must be .ply");
    if (o.bandwidth > 0 && !o.stream_chunk)
        fail(2, "--bandwidth paces the pieces of --stream-chunk: give both");
    check_progressive_options(&o);
    return o;
}

// Reads at most one byte more than the format allows, so a huge file is refused cheaply.
std::vector<unsigned char> read_file(const std::string& path) {
    std::FILE* f = std::fopen(path.c_str(), "rb");
    if (!f) fail(1, path + ": cannot open: " + std::strerror(errno));
    std::vector<unsigned char> bytes;
    unsigned char buffer[1 << 16];
    size_t n;
    while ((n = std::fread(buffer, 1, sizeof buffer, f)) > 0) {
        bytes.insert(bytes.end(), buffer, buffer + n);
        if (bytes.size() > NFD_MAX_FILE_SIZE) break;
    }
    const bool error = std::ferror(f) != 0;
    std::fclose(f);
    if (error) fail(1, path + ": read error");
    if (bytes.size() > NFD_MAX_FILE_SIZE) fail(1, path + ": larger than the format's 64 MiB cap");
    return bytes;
}

using Clock = std::chrono::steady_clock;
double ms_since(Clock::time_point t0) {
    return std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
}
// CPU time of the whole process (every thread: the CPU path's workers, lavapipe's): what a decode
// costs however busy the machine is, where wall time also counts waiting for a core.
double process_cpu_ms() { return 1e3 * double(std::clock()) / CLOCKS_PER_SEC; }

// Owns the handles so that every exit path releases them.
struct Handles {
    nfd_context* context = nullptr;
    nfd_asset* asset = nullptr;
    nfd_mesh* mesh = nullptr;
    nfd_grid* grid = nullptr;
    ~Handles() {
        nfd_grid_destroy(grid);
        nfd_mesh_destroy(mesh);
        nfd_asset_destroy(asset);
        nfd_context_destroy(context);
    }
};

// The context of o.device, its pipeline cache started from --pipeline-cache's file.
void create_context(const Options& o, nfd_context** out) {
    const std::vector<unsigned char> cache = nfc_cli::read_pipeline_cache(o.pipeline_cache);
    nfd_context_options co = {};
    co.struct_size = sizeof co;
    co.device = o.device;
    co.cpu_threads = o.threads;
    co.pipeline_cache = cache.data();
    co.pipeline_cache_size = cache.size();
    check(nfd_context_create(&co, out), "device");
}

// A cache is an optimisation: failing to save it is a warning, not a failed decode.
void save_pipeline_cache(const Options& o, const nfd_context* context) {
    if (o.pipeline_cache.empty()) return;
    const std::string why = nfc_cli::save_pipeline_cache(context, o.pipeline_cache);
    if (!why.empty())
        std::fprintf(stderr, "nfc-decode: warning: pipeline cache not saved to %s: %s\n",
                     o.pipeline_cache.c_str(), why.c_str());
}

// --stats on a Vulkan context: the buffers the decode made, the device allocations they took
// (small buffers share blocks), and what is still held (the cached network).
nfd_device_memory device_memory(const nfd_context* context) {
    nfd_device_memory m = {};
    m.struct_size = sizeof m;
    check(nfd_context_get_device_memory(context, &m), "device");
    return m;
}
void print_device_memory(const nfd_context* context) {
    if (nfd_context_device_kind(context) != NFD_DEVICE_VULKAN) return;
    const nfd_device_memory m = device_memory(context);
    std::printf("device mem  %llu buffers in %llu allocations (held after: %llu, %.2f MB)\n",
                static_cast<unsigned long long>(m.buffers_created),
                static_cast<unsigned long long>(m.allocations_made),
                static_cast<unsigned long long>(m.live_allocations), double(m.live_bytes) / 1e6);
}

const char* field_name(const nfd_asset_info& info) {
    return info.field_type == NFD_FIELD_SDF ? "SDF" : "UDF";
}

void decode_mesh(const Options& o, const nfd_asset_info& info, Handles* h) {
    nfd_mesh_options mo = {};
    mo.struct_size = sizeof mo;
    mo.resolution = o.resolution;
    mo.skip_colour = o.no_colour;
    mo.sample_band = o.sample_band;
    check(nfd_mesh_extract(h->context, h->asset, &mo, &h->mesh),
          o.input + ": meshing the " + field_name(info));
    nfd_mesh_data data;
    nfd_decode_stats stats;
    check(nfd_mesh_get_data(h->mesh, &data), "mesh");
    check(nfd_mesh_get_stats(h->mesh, &stats), "mesh");

    auto t = Clock::now();
    double ms_sample = 0;
    if (o.points) {
        if (data.triangle_count == 0) fail(1, o.input + ": the surface is empty, no points to sample");
        std::vector<float> points(3 * o.points), normals(3 * o.points), colours;
        check(nfd_mesh_sample_points(h->mesh, o.points, 0, points.data(), normals.data()),
              "point sampling");
        if (info.has_colour && !o.no_colour) {  // the colour at the points themselves
            colours.resize(3 * o.points);
            check(nfd_asset_evaluate_colour(h->context, h->asset, points.data(), o.points,
                                            colours.data()),
                  o.input + ": colour");
        }
        ms_sample = ms_since(t);
        t = Clock::now();
        double offset[3];  // non-zero for geo-referenced files: the PLY gets double x, y, z
        check(nfd_mesh_get_offset(h->mesh, offset), "mesh");
        check(nfd_points_write_placed_ply(points.data(), normals.data(),
                                          colours.empty() ? nullptr : colours.data(), o.points,
                                          offset, o.output.c_str()),
              o.output);
    } else if (ends_with(o.output, ".glb")) {
        check(nfd_mesh_write_glb(h->mesh, o.output.c_str()), o.output);
    } else {
        check(nfd_mesh_write_ply(h->mesh, o.output.c_str()), o.output);
    }
    const double ms_write = ms_since(t);

    if (o.stats) {
        std::printf("field       %9.2f ms  (%llu points evaluated)\n", stats.seconds_field * 1e3,
                    static_cast<unsigned long long>(stats.points_evaluated));
        std::printf("mesh        %9.2f ms  (%llu active cells, %.2f points evaluated per cell)\n",
                    stats.seconds_mesh * 1e3, static_cast<unsigned long long>(stats.active_cells),
                    stats.active_cells ? double(stats.points_evaluated) / double(stats.active_cells) : 0.0);
        if (o.points)
            std::printf("sample      %9.2f ms  (%zu points%s)\n", ms_sample, o.points,
                        info.has_colour && !o.no_colour ? ", with colour" : "");
        std::printf("write       %9.2f ms\n", ms_write);
        std::printf("vertices    %zu\ntriangles   %zu\n", data.vertex_count, data.triangle_count);
        print_device_memory(h->context);
    }
}

void decode_grid(const Options& o, Handles* h) {
    auto t = Clock::now();
    nfd_grid_options go = {};
    go.struct_size = sizeof go;
    go.resolution = o.resolution;
    go.skip_colour = o.no_colour;
    check(nfd_grid_extract(h->context, h->asset, &go, &h->grid), o.input + ": sampling the grid");
    nfd_grid_voxels voxels;
    check(nfd_grid_get_voxels(h->grid, &voxels), "grid");
    const double ms_field = ms_since(t);

    t = Clock::now();
    // The metadata records the input's file name, not the path it was given by.
    const size_t slash = o.input.find_last_of("/\\");
    const std::string name = slash == std::string::npos ? o.input : o.input.substr(slash + 1);
    const nfd_result r = nfd_grid_write_vdb(h->grid, o.output.c_str(), name.c_str());
    if (r == NFD_ERROR_UNSUPPORTED_FEATURE)
        fail(1, o.output + ": this libnfdecode cannot write OpenVDB files: built without OpenVDB "
                           "(NFD_WITH_OPENVDB=OFF), or its module libnfdecode_vdb.so not found "
                           "(see NFD_VDB_MODULE)");
    check(r, o.output);
    const double ms_write = ms_since(t);

    if (o.stats) {
        const double dense = std::pow(double(voxels.resolution) + 1.0, 3.0);
        std::printf("field       %9.2f ms\n", ms_field);
        std::printf("write       %9.2f ms\n", ms_write);
        std::printf("voxels      %zu (%.2f%% of the dense %u^3 grid's vertices)\n", voxels.count,
                    100.0 * double(voxels.count) / dense, voxels.resolution + 1);
    }
}

// How the asset was read, for --stats.
struct Input {
    double ms_read = 0, ms_parse = 0;  // receiving the bytes; inside the parser
    double ms_geometry = -1;           // streamed: first piece to asset ready; < 0 otherwise
    unsigned long long geometry_byte = 0;  // streamed: bytes in when the asset was ready
};

// The whole file, then nfd_asset_create.
Input read_asset(const Options& o, nfd_asset** asset) {
    Input in;
    auto t = Clock::now();
    const std::vector<unsigned char> bytes = read_file(o.input);
    in.ms_read = ms_since(t);
    t = Clock::now();
    check(nfd_asset_create(bytes.data(), bytes.size(), asset), o.input);
    in.ms_parse = ms_since(t);
    return in;
}

// --stream-chunk: the file read piece by piece into nfd_stream, paced by --bandwidth, never held
// whole; the asset is taken as soon as the stream has the geometry, and the stream must still
// finish cleanly (a damaged or truncated tail fails the decode, as without streaming). A context
// that exists already (--levels) compiles the network's pipelines while the weights arrive.
Input stream_asset(const Options& o, nfd_context* context, nfd_asset** asset) {
    std::FILE* f = std::fopen(o.input.c_str(), "rb");
    if (!f) fail(1, o.input + ": cannot open: " + std::strerror(errno));
    const std::unique_ptr<std::FILE, int (*)(std::FILE*)> file(f, &std::fclose);
    nfd_stream* s = nullptr;
    nfd_stream_options so = {};
    so.struct_size = sizeof so;
    so.prepare_context = context;
    check(nfd_stream_create(&so, &s), "stream");
    const std::unique_ptr<nfd_stream, void (*)(nfd_stream*)> stream(s, &nfd_stream_destroy);

    Input in;
    std::vector<unsigned char> piece(o.stream_chunk);
    const auto t0 = Clock::now();
    unsigned long long arrived = 0;
    size_t n;
    while ((n = std::fread(piece.data(), 1, piece.size(), f)) > 0) {
        arrived += n;
        if (o.bandwidth > 0)  // the piece is complete when its last byte would have arrived
            std::this_thread::sleep_until(
                t0 + std::chrono::duration_cast<Clock::duration>(
                         std::chrono::duration<double>(double(arrived) / o.bandwidth)));
        const auto t = Clock::now();
        nfd_stream_progress progress;
        const nfd_result r = nfd_stream_feed(s, piece.data(), n, &progress);
        in.ms_parse += ms_since(t);
        check(r, o.input);
        if (!*asset && (progress.flags & NFD_STREAM_GEOMETRY_READY)) {
            check(nfd_stream_take_asset(s, asset), o.input);
            in.ms_geometry = ms_since(t0);
            in.geometry_byte = progress.bytes_consumed;
        }
    }
    if (std::ferror(f)) fail(1, o.input + ": read error");
    check(nfd_stream_finish(s), o.input);
    // The decode uses the whole file (colour arrives after the geometry).
    nfd_asset* complete = nullptr;
    check(nfd_stream_take_complete_asset(s, &complete), o.input);
    nfd_asset_destroy(*asset);
    *asset = complete;
    in.ms_read = ms_since(t0) - in.ms_parse;
    return in;
}

Input acquire_asset(const Options& o, nfd_context* context, nfd_asset** asset) {
    return o.stream_chunk ? stream_asset(o, context, asset) : read_asset(o, asset);
}

// OUT.<resolution>.<ext>: bunny.glb -> bunny.64.glb.
std::string level_path(const std::string& output, uint32_t resolution) {
    const size_t dot = output.size() - 4;  // ".glb" or ".ply"
    return output.substr(0, dot) + "." + std::to_string(resolution) + output.substr(dot);
}

void write_mesh(const nfd_mesh* mesh, const std::string& path) {
    check(ends_with(path, ".glb") ? nfd_mesh_write_glb(mesh, path.c_str())
                                  : nfd_mesh_write_ply(mesh, path.c_str()),
          path);
}

// --levels: the context first (as an engine's exists before a file arrives), then the clock
// from the first byte read (fed piece by piece with --stream-chunk), one extraction step per
// ladder level. Files are
// written after the last level so that writing does not count in the levels' times.
void decode_progressive(const Options& o, Handles* h) {
    create_context(o, &h->context);

    const auto t0 = Clock::now();
    const double cpu0 = process_cpu_ms();
    const Input in = acquire_asset(o, h->context, &h->asset);
    const double ms_asset = ms_since(t0);
    nfd_extraction_options eo = {};
    eo.struct_size = sizeof eo;
    eo.resolution = o.resolution;
    eo.mesh_levels = nfc_cli::ladder_mask(o.levels);
    eo.skip_colour = o.no_colour;
    eo.sample_band = o.sample_band;
    struct Extraction {
        nfd_extraction* handle = nullptr;
        std::vector<nfd_mesh*> meshes;
        ~Extraction() {
            for (nfd_mesh* m : meshes) nfd_mesh_destroy(m);
            nfd_extraction_destroy(handle);
        }
    } ex;
    check(nfd_extraction_create(h->context, h->asset, &eo, &ex.handle), o.input);
    const double ms_prepare = ms_since(t0) - ms_asset;
    if (o.stats && !o.stats_json)
        std::printf("asset       %9.2f ms\nprepare     %9.2f ms\n", ms_asset, ms_prepare);
    uint64_t points = 0, gradients = 0;
    nfd_extraction_level info = {};
    do {
        info.struct_size = sizeof info;
        nfd_mesh* mesh = nullptr;
        check(nfd_extraction_step(ex.handle, &mesh, &info), o.input + ": a progressive step");
        const double elapsed = ms_since(t0);
        points += info.points_evaluated;
        gradients += info.gradients_evaluated;
        if (!mesh) continue;
        ex.meshes.push_back(mesh);
        nfd_mesh_data data;
        check(nfd_mesh_get_data(mesh, &data), "mesh");
        if (o.stats_json)
            std::printf("{\"resolution\":%u,\"elapsed_ms\":%.3f,\"triangles\":%zu,"
                        "\"points_evaluated\":%llu}\n",
                        info.resolution, elapsed, data.triangle_count,
                        static_cast<unsigned long long>(info.points_evaluated));
        else if (o.stats)
            std::printf("level %-5u %9.2f ms  %zu triangles, %llu new points\n", info.resolution,
                        elapsed, data.triangle_count,
                        static_cast<unsigned long long>(info.points_evaluated));
    } while (!info.done);
    const double total = ms_since(t0), cpu = process_cpu_ms() - cpu0;
    if (o.stats_json) {
        const nfd_device_memory memory = device_memory(h->context);
        std::printf("{\"summary\":true,\"device\":\"%s\",\"resolution\":%u,\"levels\":%zu,"
                    "\"elapsed_ms\":%.3f,\"cpu_ms\":%.3f,\"asset_ms\":%.3f,\"geometry_ms\":%.3f,"
                    "\"prepare_ms\":%.3f,\"points_evaluated\":%llu,\"gradients_evaluated\":%llu,"
                    "\"device_buffers\":%llu,\"device_allocations\":%llu}\n",
                    nfd_context_device_name(h->context), o.resolution, ex.meshes.size(), total,
                    cpu, ms_asset, in.ms_geometry >= 0 ? in.ms_geometry : ms_asset, ms_prepare,
                    static_cast<unsigned long long>(points),
                    static_cast<unsigned long long>(gradients),
                    static_cast<unsigned long long>(memory.buffers_created),
                    static_cast<unsigned long long>(memory.allocations_made));
    } else if (o.stats) {
        print_device_memory(h->context);
    }

    write_mesh(ex.meshes.back(), o.output);
    if (o.write_levels)
        for (size_t i = 0; i < ex.meshes.size(); ++i)
            write_mesh(ex.meshes[i], level_path(o.output, o.levels[i]));
}

void run(const Options& o) {
    Handles h;
    if (!o.levels.empty()) {
        decode_progressive(o, &h);
        return save_pipeline_cache(o, h.context);
    }
    const Input in = acquire_asset(o, nullptr, &h.asset);
    nfd_asset_info info;
    check(nfd_asset_get_info(h.asset, &info), o.input);

    auto t = Clock::now();
    create_context(o, &h.context);
    const double ms_device = ms_since(t);

    if (o.stats) {
        std::printf("file        %u bytes (format %u.%u, %s, %u-bit, %u layers, width %u%s)\n",
                    info.file_size, info.format_major, info.format_minor, field_name(info),
                    info.bits, info.num_layers, info.layer_widths[0],
                    info.has_colour ? o.no_colour ? ", colour skipped" : ", colour" : "");
        nfd_asset_frame frame{};
        frame.struct_size = sizeof frame;
        check(nfd_asset_get_frame(h.asset, &frame), o.input);
        if (frame.exact64)
            std::printf("offset      (%.17g, %.17g, %.17g)  (64-bit frame: positions are local "
                        "to it)\n",
                        frame.offset[0], frame.offset[1], frame.offset[2]);
        std::printf("device      %s (%s)\n", nfd_context_device_name(h.context),
                    nfd_context_device_reason(h.context));
        std::printf("read        %9.2f ms\n", in.ms_read);
        std::printf("parse       %9.2f ms\n", in.ms_parse);
        if (in.ms_geometry >= 0)
            std::printf("geometry    %9.2f ms  (asset ready at byte %llu of %u)\n", in.ms_geometry,
                        in.geometry_byte, info.file_size);
        std::printf("device init %9.2f ms\n", ms_device);
    }
    if (ends_with(o.output, ".vdb"))
        decode_grid(o, &h);
    else
        decode_mesh(o, info, &h);
    save_pipeline_cache(o, h.context);
}

}  // namespace

int main(int argc, char** argv) {
    try {
        run(parse_args(argc, argv));
        return 0;
    } catch (const Failure& f) {
        std::fprintf(stderr, "nfc-decode: error: %s\n", f.message.c_str());
        return f.status;
    } catch (const std::exception& e) {  // std::bad_alloc reading a file, mostly
        std::fprintf(stderr, "nfc-decode: error: %s\n", e.what());
        return 1;
    }
}
