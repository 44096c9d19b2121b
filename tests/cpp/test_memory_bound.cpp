// The queue's reservation of each step of a job (extract_work.h) against what the job really
// holds during the step, from before the job existed: every heap byte through operator new
// (replaced below, hence an executable of its own) and, on Vulkan, every buffer's memory
// (gpu::device_memory). The first step's bound is measured (extract_bytes_bound), the later ones
// are the progressive extraction's true bounds plus what the job keeps. On the golden vectors, SDF
// and UDF, at several resolutions, every level meshed and the newest mesh kept as a job keeps it,
// on the CPU and (where there is one) the Vulkan device.
#include <gtest/gtest.h>
#include <malloc.h>

#include <atomic>
#include <cstdio>
#include <cstdlib>
#include <functional>
#include <new>
#include <optional>
#include <type_traits>

#include "extract.h"
#include "extract_work.h"
#include "grid.h"
#include "test_util.h"
#if NFD_WITH_VULKAN
#include "gpu/gpu_decode.h"
#endif

namespace {

std::atomic<int64_t> g_live{0}, g_peak{0};

void count(int64_t bytes) {
    const int64_t now = g_live.fetch_add(bytes) + bytes;
    int64_t peak = g_peak.load();
    while (now > peak && !g_peak.compare_exchange_weak(peak, now)) {
    }
}

}  // namespace

// malloc_usable_size: what the allocator really handed out, so that delete counts the same.
void* operator new(size_t size) {
    void* p = std::malloc(size ? size : 1);
    if (!p) throw std::bad_alloc();
    count(int64_t(malloc_usable_size(p)));
    return p;
}
void operator delete(void* p) noexcept {
    if (!p) return;
    count(-int64_t(malloc_usable_size(p)));
    std::free(p);
}
void operator delete(void* p, size_t) noexcept { operator delete(p); }

namespace nfd::test {
namespace {

const uint32_t kResolutions[] = {48, 64, 128, 256};  // first steps at 48 and 32 cells

// Runs a job's steps as a worker does, keeping the newest delivered mesh (the job holds it until
// it is taken or replaced), and checks every step's peak against its reservation.
void job_stays_within_its_reservations(const Geometry& g, uint32_t r, gpu::Device* device) {
    const uint32_t every_level = (2u << refinement_levels(r)) - 1;
#if NFD_WITH_VULKAN
    // The device keeps uploaded networks for later decodes (gpu/device.h, device_network): upload
    // this one first, so that what the job leaves behind is nothing at all.
    float value;
    const float point[3] = {0, 0, 0};
    if (device) ASSERT_EQ(gpu::evaluate(*device, g.network, point, 1, &value), NFD_SUCCESS);
    const uint64_t device_base = device ? gpu::device_memory(*device).live : 0;
#endif
    const int64_t base = g_live.load();
    {
        ExtractWork work(g, std::nullopt, r, every_level, device, 2);
        std::optional<MeshResult> kept;
        for (uint32_t s = 0;; ++s) {
            const MemoryBytes reserved = work.next_step_bytes();
            g_peak.store(g_live.load());
#if NFD_WITH_VULKAN
            if (device) gpu::reset_device_memory_peak(*device);
#endif
            StepResult step;
            ASSERT_EQ(work.step(&step), NFD_SUCCESS);
            const uint64_t host = uint64_t(g_peak.load() - base);
            uint64_t device_peak = 0;
#if NFD_WITH_VULKAN
            if (device) device_peak = gpu::device_memory(*device).peak - device_base;
#endif
            std::printf("%s %4u step %u  host %6.1f MB (reserved %6.1f)  device %6.1f MB "
                        "(reserved %6.1f)\n",
                        device ? "vk " : "cpu", r, s, host / 1e6, reserved.host / 1e6,
                        device_peak / 1e6, reserved.device / 1e6);
            EXPECT_LE(host, reserved.host) << r << " step " << s;
            EXPECT_LE(device_peak, reserved.device) << r << " step " << s;
            if (step.mesh) kept = std::move(step.mesh);
            if (step.finished) break;
        }
        EXPECT_TRUE(kept);
    }
#if NFD_WITH_VULKAN
    if (device) EXPECT_EQ(gpu::device_memory(*device).live, device_base);  // all freed
#endif
}

TEST(MemoryBound, CpuJobStaysWithinItsReservations) {
    for (const std::string& name : golden_names()) {
        SCOPED_TRACE(name);
        const Geometry g = parse_or_throw(read_bytes(golden_path(name, ".nfc")));
        for (uint32_t r : kResolutions) job_stays_within_its_reservations(g, r, nullptr);
    }
}

#if NFD_WITH_VULKAN
TEST(MemoryBound, VulkanJobStaysWithinItsReservations) {
    std::unique_ptr<gpu::Device> device;
    if (gpu::create_device(nullptr, false, &device) != NFD_SUCCESS) {
        if (std::getenv("NFD_REQUIRE_VULKAN")) FAIL() << "no Vulkan device";
        GTEST_SKIP() << "no Vulkan device";
    }
    for (const std::string& name : golden_names()) {
        SCOPED_TRACE(name);
        const Geometry g = parse_or_throw(read_bytes(golden_path(name, ".nfc")));
        for (uint32_t r : kResolutions) job_stays_within_its_reservations(g, r, device.get());
    }
}
#endif

// The memory limits of one decode (nfd_mesh_options / nfd_grid_options max_host_bytes): at the
// smallest limit a decode accepts (found by bisection), what it really holds at its peak, the
// result included, stays within that limit. CPU path; SDF, UDF and coloured golden vectors at 128.
uint64_t peak_under_limit(const std::function<nfd_result(uint64_t)>& decode, uint64_t limit) {
    const int64_t base = g_live.load();
    g_peak.store(base);
    EXPECT_EQ(decode(limit), NFD_SUCCESS);
    return uint64_t(g_peak.load() - base);
}

void smallest_limit_holds(const std::function<nfd_result(uint64_t)>& decode) {
    uint64_t refused = 1u << 16, accepted = uint64_t(1) << 34;
    ASSERT_EQ(decode(refused), NFD_ERROR_LIMIT_EXCEEDED);
    ASSERT_EQ(decode(accepted), NFD_SUCCESS);
    while (accepted - refused > accepted / 64) {
        const uint64_t mid = refused + (accepted - refused) / 2;
        (decode(mid) == NFD_SUCCESS ? accepted : refused) = mid;
    }
    const uint64_t peak = peak_under_limit(decode, accepted);
    std::printf("limit %7.1f MB  peak %7.1f MB\n", accepted / 1e6, peak / 1e6);
    EXPECT_LE(peak, accepted);
}

// A decode at 128 under `limit`: a mesh (nfd_mesh_options) or a grid (nfd_grid_options), freed.
template <class Options>
nfd_result decode_with_limit(nfd_context* ctx, const nfd_asset* asset, uint64_t limit) {
    Options o{};
    o.struct_size = sizeof o;
    o.resolution = 128;
    o.max_host_bytes = limit;
    if constexpr (std::is_same_v<Options, nfd_mesh_options>) {
        nfd_mesh* mesh = nullptr;
        const nfd_result r = nfd_mesh_extract(ctx, asset, &o, &mesh);
        nfd_mesh_destroy(mesh);
        return r;
    } else {
        nfd_grid* grid = nullptr;
        const nfd_result r = nfd_grid_extract(ctx, asset, &o, &grid);
        nfd_grid_destroy(grid);
        return r;
    }
}

TEST(MemoryBound, LimitsAreNeverExceeded) {
    nfd_context_options co{};
    co.struct_size = sizeof co;
    co.device = NFD_DEVICE_CPU;
    co.cpu_threads = 2;
    nfd_context* ctx = nullptr;
    ASSERT_EQ(nfd_context_create(&co, &ctx), NFD_SUCCESS);
    for (const std::string name : {"bunny_sdf_w16", "tshirt_udf_w16", "milk_udf_w16_c16"}) {
        SCOPED_TRACE(name);
        const Bytes bytes = read_bytes(golden_path(name, ".nfc"));
        nfd_asset* asset = nullptr;
        ASSERT_EQ(nfd_asset_create(bytes.data(), bytes.size(), &asset), NFD_SUCCESS);
        smallest_limit_holds(
            [&](uint64_t limit) { return decode_with_limit<nfd_mesh_options>(ctx, asset, limit); });
        smallest_limit_holds(
            [&](uint64_t limit) { return decode_with_limit<nfd_grid_options>(ctx, asset, limit); });
        nfd_asset_destroy(asset);
    }
    nfd_context_destroy(ctx);
}

}  // namespace
}  // namespace nfd::test
