// Decodes recorded into a host's command buffer (nfd_recording) against the library's own
// submission on the same adopted device: for each asset and resolution, the capacities the decode
// needed (found by recording again with nfd_recording_result's needed_* until it fits, starting
// from the defaults), per (r / 64)^2 as the defaults are stated, whether the defaults sufficed,
// the recording's device bytes, and the times: the host thread's CPU time in
// nfd_recording_record (what recording costs a frame), the host's submit-to-fence wall time, and
// nfd_mesh_extract's wall time. Prints one markdown table; checks that both meshes are equal.
//
//     build/bench/recording --resolutions 64,128,256,512 bench/out/nfc/*.nfc tests/vectors/*.nfc
#include <nfdecode/nfdecode.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

#include <time.h>

#include "../tests/cpp/host_vulkan.h"

namespace {

using Clock = std::chrono::steady_clock;
double seconds_since(Clock::time_point t0) {
    return std::chrono::duration<double>(Clock::now() - t0).count();
}
double thread_cpu() {
    timespec t;
    clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
    return double(t.tv_sec) + 1e-9 * double(t.tv_nsec);
}

struct Try {
    nfd_result result = NFD_ERROR_INTERNAL;
    nfd_recording_result totals{};
    double record_cpu_s = 0, gpu_wall_s = 0;
    std::vector<float> positions;
    std::vector<uint32_t> indices;
};

// One recording: create, record into a fresh command buffer, submit, wait, finish, read back.
Try record_once(nfd::test::HostVulkan& host, VkCommandPool pool, nfd_context* ctx,
                const nfd_asset* asset, const nfd_recording_options& options) {
    Try t;
    nfd_recording* rec = nullptr;
    t.result = nfd_recording_create(ctx, asset, &options, &rec);
    if (t.result != NFD_SUCCESS) return t;
    VkCommandBuffer cmd = host.begin_commands(pool);
    const double c0 = thread_cpu();
    t.result = nfd_recording_record(rec, cmd);
    t.record_cpu_s = thread_cpu() - c0;
    if (t.result == NFD_SUCCESS) {
        const auto t0 = Clock::now();
        const bool ran = host.submit_and_wait(cmd);
        t.gpu_wall_s = seconds_since(t0);
        t.totals.struct_size = sizeof t.totals;
        // Without the wait the commands may still run: the recording is then leaked, not freed.
        if (!ran) {
            t.result = NFD_ERROR_DEVICE;
            return t;
        }
        t.result = nfd_recording_finish(rec, &t.totals);
        nfd_mesh* mesh = nullptr;
        if (t.result == NFD_SUCCESS && nfd_recording_read_mesh(rec, &mesh) == NFD_SUCCESS) {
            nfd_mesh_data d;
            nfd_mesh_get_data(mesh, &d);
            t.positions.assign(d.positions, d.positions + 3 * d.vertex_count);
            t.indices.assign(d.indices, d.indices + 3 * d.triangle_count);
            nfd_mesh_destroy(mesh);
        }
    }
    vkFreeCommandBuffers(host.device, pool, 1, &cmd);
    nfd_recording_destroy(rec);
    return t;
}

std::vector<uint32_t> parse_list(const char* s) {
    std::vector<uint32_t> out;
    for (const char* p = s; *p;) {
        out.push_back(uint32_t(std::strtoul(p, nullptr, 10)));
        p = std::strchr(p, ',');
        if (!p) break;
        ++p;
    }
    return out;
}

}  // namespace

int main(int argc, char** argv) {
    std::vector<uint32_t> resolutions = {64, 128, 256};
    std::vector<std::string> files;
    for (int i = 1; i < argc; ++i) {
        if (!std::strcmp(argv[i], "--resolutions") && i + 1 < argc) resolutions = parse_list(argv[++i]);
        else files.push_back(argv[i]);
    }
    if (files.empty()) {
        std::fprintf(stderr, "usage: recording [--resolutions 64,128,256] FILE.nfc...\n");
        return 2;
    }
    nfd::test::HostVulkan host;
    const std::string why = host.create();
    if (!why.empty()) {
        std::fprintf(stderr, "recording: %s\n", why.c_str());
        return 1;
    }
    const nfd_vulkan_device lent = host.lend();
    nfd_context_options options{};
    options.struct_size = sizeof options;
    options.adopt = &lent;
    nfd_context* ctx = nullptr;
    if (nfd_context_create(&options, &ctx) != NFD_SUCCESS) {
        std::fprintf(stderr, "recording: no context on the host's device\n");
        return 1;
    }
    VkCommandPoolCreateInfo pool_info{};
    pool_info.sType = VK_STRUCTURE_TYPE_COMMAND_POOL_CREATE_INFO;
    pool_info.queueFamilyIndex = host.family;
    VkCommandPool pool;
    vkCreateCommandPool(host.device, &pool_info, nullptr, &pool);

    std::printf("device: %s\n\n", nfd_context_device_name(ctx));
    std::printf("| asset | r | cells/q | gradients/q | vertices/q | triangles/q | defaults fit | "
                "tries | record CPU ms | recorded wall ms | own wall ms | same mesh |\n");
    std::printf("|---|---:|---:|---:|---:|---:|:-:|---:|---:|---:|---:|:-:|\n");
    int status = 0;
    for (const std::string& path : files) {
        std::ifstream in(path, std::ios::binary);
        const std::vector<char> bytes((std::istreambuf_iterator<char>(in)), {});
        nfd_asset* asset = nullptr;
        if (nfd_asset_create(bytes.data(), bytes.size(), &asset) != NFD_SUCCESS) {
            std::fprintf(stderr, "recording: %s: not a decodable .nfc\n", path.c_str());
            status = 1;
            continue;
        }
        const std::string name = path.substr(path.find_last_of('/') + 1);
        for (uint32_t r : resolutions) {
            nfd_recording_options ro{};
            ro.struct_size = sizeof ro;
            ro.resolution = r;
            Try t = record_once(host, pool, ctx, asset, ro);
            const bool defaults_fit = t.result == NFD_SUCCESS;
            int tries = 1;
            while (t.result == NFD_ERROR_CAPACITY_EXCEEDED && tries < 10) {
                ro.max_cells = t.totals.needed_cells;
                ro.max_gradient_points = t.totals.needed_gradient_points;
                ro.max_vertices = t.totals.needed_vertices;
                ro.max_triangles = t.totals.needed_triangles;
                t = record_once(host, pool, ctx, asset, ro);
                ++tries;
            }
            if (t.result != NFD_SUCCESS) {
                std::fprintf(stderr, "recording: %s at %u: %s\n", name.c_str(), r,
                             nfd_result_string(t.result));
                status = 1;
                continue;
            }
            // What it used: the needed capacities of a run that fit are the given ones raised to
            // the totals, so record once more from tiny capacities to read the totals themselves.
            nfd_recording_options exact{};
            exact.struct_size = sizeof exact;
            exact.resolution = r;
            exact.max_cells = exact.max_gradient_points = exact.max_vertices =
                exact.max_triangles = 1;
            Try e = record_once(host, pool, ctx, asset, exact);
            for (int i = 0; e.result == NFD_ERROR_CAPACITY_EXCEEDED && i < 10; ++i) {
                exact.max_cells = e.totals.needed_cells;
                exact.max_gradient_points = e.totals.needed_gradient_points;
                exact.max_vertices = e.totals.needed_vertices;
                exact.max_triangles = e.totals.needed_triangles;
                e = record_once(host, pool, ctx, asset, exact);
            }
            nfd_mesh_options mo{};
            mo.resolution = r;
            nfd_mesh* own = nullptr;
            const auto t0 = Clock::now();
            nfd_mesh_extract(ctx, asset, &mo, &own);
            const double own_s = seconds_since(t0);
            nfd_mesh_data d{};
            if (own) nfd_mesh_get_data(own, &d);
            const bool same =
                own && t.indices.size() == 3 * d.triangle_count &&
                std::equal(t.indices.begin(), t.indices.end(), d.indices) &&
                t.positions.size() == 3 * d.vertex_count &&
                std::equal(t.positions.begin(), t.positions.end(), d.positions);
            nfd_mesh_destroy(own);
            if (!same) status = 1;
            const double q = double(r) * r / 4096.0;
            std::printf("| %s | %u | %.0f | %.0f | %.0f | %.0f | %s | %d | %.1f | %.0f | %.0f | %s |\n",
                        name.c_str(), r, exact.max_cells / q, exact.max_gradient_points / q,
                        exact.max_vertices / q, exact.max_triangles / q,
                        defaults_fit ? "yes" : "no", tries, 1e3 * t.record_cpu_s,
                        1e3 * t.gpu_wall_s, 1e3 * own_s, same ? "yes" : "NO");
            std::fflush(stdout);
        }
        nfd_asset_destroy(asset);
    }
    vkDestroyCommandPool(host.device, pool, nullptr);
    nfd_context_destroy(ctx);
    return status;
}
