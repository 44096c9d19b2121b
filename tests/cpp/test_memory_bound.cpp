// The queue's memory bound of one extraction (extract_work.h) against what the extraction really
// allocates: every heap byte through operator new (replaced below, hence an executable of its own)
// and, on Vulkan, every buffer's memory (gpu::device_memory). On the golden vectors, SDF and
// UDF, at several resolutions, on the CPU and (where there is one) the Vulkan device.
#include <gtest/gtest.h>
#include <malloc.h>

#include <atomic>
#include <cstdio>
#include <cstdlib>
#include <new>

#include "extract.h"
#include "extract_work.h"
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

const uint32_t kResolutions[] = {64, 128, 256};

// Peak heap bytes above the level at the start of fn().
template <class Fn>
uint64_t peak_heap_of(Fn&& fn) {
    const int64_t base = g_live.load();
    g_peak.store(base);
    fn();
    return uint64_t(g_peak.load() - base);
}

TEST(MemoryBound, CpuExtractionStaysWithinTheBound) {
    for (const std::string& name : golden_names()) {
        const Geometry g = parse_or_throw(read_bytes(golden_path(name, ".nfc")));
        for (uint32_t r : kResolutions) {
            const MemoryBytes bound = extract_bytes_bound(g, r, false);
            EXPECT_EQ(bound.device, 0u);
            const uint64_t peak = peak_heap_of([&] {
                ExtractWork work(g, r, nullptr, 2);
                StepResult step;
                ASSERT_EQ(work.step(&step), NFD_SUCCESS);
                ASSERT_TRUE(step.finished && step.mesh);
            });
            std::printf("cpu %-22s %4u  peak %6.1f MB  bound %6.1f MB\n", name.c_str(), r,
                        peak / 1e6, bound.host / 1e6);
            EXPECT_LE(peak, bound.host) << name << " at " << r;
        }
    }
}

#if NFD_WITH_VULKAN
TEST(MemoryBound, VulkanExtractionStaysWithinTheBound) {
    std::unique_ptr<gpu::Device> device;
    if (gpu::create_device(nullptr, false, &device) != NFD_SUCCESS) {
        if (std::getenv("NFD_REQUIRE_VULKAN")) FAIL() << "no Vulkan device";
        GTEST_SKIP() << "no Vulkan device";
    }
    for (const std::string& name : golden_names()) {
        const Geometry g = parse_or_throw(read_bytes(golden_path(name, ".nfc")));
        for (uint32_t r : kResolutions) {
            const MemoryBytes bound = extract_bytes_bound(g, r, true);
            gpu::reset_device_memory_peak(*device);
            const uint64_t device_before = gpu::device_memory(*device).live;
            const uint64_t peak = peak_heap_of([&] {
                ExtractWork work(g, r, device.get(), 0);
                StepResult step;
                ASSERT_EQ(work.step(&step), NFD_SUCCESS);
                ASSERT_TRUE(step.finished && step.mesh);
            });
            const uint64_t device_peak = gpu::device_memory(*device).peak - device_before;
            std::printf("vk  %-22s %4u  host %6.1f MB (bound %6.1f)  device %6.1f MB "
                        "(bound %6.1f)\n",
                        name.c_str(), r, peak / 1e6, bound.host / 1e6, device_peak / 1e6,
                        bound.device / 1e6);
            EXPECT_LE(peak, bound.host) << name << " at " << r;
            EXPECT_LE(device_peak, bound.device) << name << " at " << r;
            EXPECT_EQ(gpu::device_memory(*device).live, device_before);  // the job's buffers are freed
        }
    }
}
#endif

}  // namespace
}  // namespace nfd::test
