// Host memory hooks (nfdecode.h, "Host memory"; host_memory.h): what a decode allocates goes
// through the installed functions and is all given back to them, a failing allocate ends the
// call in NFD_ERROR_OUT_OF_MEMORY without a leak or a crash, and the functions are only replaced
// while nothing they allocated is alive.
#include <gtest/gtest.h>
#include <nfdecode/nfdecode.h>

#include <atomic>
#include <cstdio>
#include <new>

#include "alloc_tracking.h"
#include "test_util.h"

namespace nfd::test {
namespace {

// A host heap over operator new (so that the test executable's tracking sees it too) that
// counts its live allocations and bytes, and refuses every request after the first `budget`.
struct CountingHeap {
    std::atomic<int64_t> live{0}, bytes{0}, peak_bytes{0}, calls{0};
    std::atomic<int64_t> budget{INT64_MAX};

    static void* allocate(void* user, size_t size) {
        auto& h = *static_cast<CountingHeap*>(user);
        if (h.calls++ >= h.budget) return nullptr;
        auto* block = static_cast<size_t*>(::operator new(size + 16, std::nothrow));
        if (!block) return nullptr;
        block[0] = size;  // 16 bytes of header keep the 16-byte alignment
        ++h.live;
        const int64_t now = h.bytes += int64_t(size);
        int64_t seen = h.peak_bytes.load();
        while (now > seen && !h.peak_bytes.compare_exchange_weak(seen, now)) {
        }
        return block + 2;
    }
    static void deallocate(void* user, void* address) {
        auto& h = *static_cast<CountingHeap*>(user);
        size_t* block = static_cast<size_t*>(address) - 2;
        --h.live;
        h.bytes -= int64_t(block[0]);
        ::operator delete(block);
    }
    nfd_allocator hooks() {
        nfd_allocator a{};
        a.struct_size = sizeof a;
        a.allocate = &CountingHeap::allocate;
        a.deallocate = &CountingHeap::deallocate;
        a.user = this;
        return a;
    }
};

// Installs a heap's hooks for one test and takes them out again.
class HostMemory : public ::testing::Test {
protected:
    void SetUp() override {
        const nfd_allocator hooks = heap_.hooks();
        ASSERT_EQ(nfd_set_allocator(&hooks), NFD_SUCCESS);
    }
    void TearDown() override {
        EXPECT_EQ(nfd_set_allocator(nullptr), NFD_SUCCESS);  // nothing left alive
        EXPECT_EQ(heap_.live.load(), 0) << "allocations not given back";
        EXPECT_EQ(heap_.bytes.load(), 0);
    }
    CountingHeap heap_;
};

nfd_context* cpu_context(unsigned threads) {
    nfd_context_options o{};
    o.struct_size = sizeof o;
    o.device = NFD_DEVICE_CPU;
    o.cpu_threads = threads;
    nfd_context* ctx = nullptr;
    return nfd_context_create(&o, &ctx) == NFD_SUCCESS ? ctx : nullptr;
}

// The objects of one CPU decode, each step allowed to fail with NFD_ERROR_OUT_OF_MEMORY only;
// `complete` when every step succeeded.
struct Decode {
    nfd_result context = NFD_ERROR_INTERNAL, asset = NFD_ERROR_INTERNAL,
               mesh = NFD_ERROR_INTERNAL, stream = NFD_ERROR_INTERNAL;
    bool complete() const {
        return context == NFD_SUCCESS && asset == NFD_SUCCESS && mesh == NFD_SUCCESS &&
               stream == NFD_SUCCESS;
    }
};
Decode decode(const Bytes& bytes, uint32_t resolution, unsigned threads, size_t* triangles) {
    Decode d;
    nfd_context* ctx = nullptr;
    nfd_context_options o{};
    o.struct_size = sizeof o;
    o.device = NFD_DEVICE_CPU;
    o.cpu_threads = threads;
    d.context = nfd_context_create(&o, &ctx);
    nfd_asset* asset = nullptr;
    d.asset = nfd_asset_create(bytes.data(), bytes.size(), &asset);
    if (d.context == NFD_SUCCESS && d.asset == NFD_SUCCESS) {
        nfd_mesh_options mo{};
        mo.struct_size = sizeof mo;
        mo.resolution = resolution;
        nfd_mesh* mesh = nullptr;
        d.mesh = nfd_mesh_extract(ctx, asset, &mo, &mesh);
        nfd_mesh_data data{};
        if (d.mesh == NFD_SUCCESS && nfd_mesh_get_data(mesh, &data) == NFD_SUCCESS && triangles)
            *triangles = data.triangle_count;
        nfd_mesh_destroy(mesh);
    }
    // The same file through a stream, 100 bytes a call.
    nfd_stream* stream = nullptr;
    d.stream = nfd_stream_create(nullptr, &stream);
    for (size_t at = 0; d.stream == NFD_SUCCESS && at < bytes.size(); at += 100)
        d.stream = nfd_stream_feed(stream, bytes.data() + at, std::min<size_t>(100, bytes.size() - at),
                                   nullptr);
    if (d.stream == NFD_SUCCESS) d.stream = nfd_stream_finish(stream);
    nfd_stream_destroy(stream);
    nfd_asset_destroy(asset);
    nfd_context_destroy(ctx);
    return d;
}

bool out_of_memory_or_success(nfd_result r) {
    return r == NFD_SUCCESS || r == NFD_ERROR_OUT_OF_MEMORY;
}

TEST_F(HostMemory, ServesTheDecodeAndGetsEverythingBack) {
    const Bytes bytes = read_bytes(golden_path("tshirt_udf_w16", ".nfc"));
    g_peak_live_bytes = g_live_bytes.load();
    const int64_t baseline = g_live_bytes.load();
    size_t triangles = 0;
    const Decode d = decode(bytes, 128, 2, &triangles);
    ASSERT_TRUE(d.complete());
    EXPECT_GT(triangles, 1000u);
    EXPECT_GT(heap_.calls.load(), 10);
    EXPECT_EQ(heap_.live.load(), 0);
    // At the peak most of the live heap is the hooks' (the rest: fixed bookkeeping, the C++
    // runtime's own; alloc_tracking counts malloc's usable sizes, slightly more than asked).
    const double share = double(heap_.peak_bytes.load()) / double(g_peak_live_bytes - baseline);
    std::printf("hooks' peak %lld bytes of the heap's %lld: %.1f%%\n",
                static_cast<long long>(heap_.peak_bytes.load()),
                static_cast<long long>(g_peak_live_bytes - baseline), 100 * share);
    ::testing::Test::RecordProperty("hooks_share_of_peak", std::to_string(share));
    EXPECT_GT(share, 0.9);
}

// Every allocation of a small decode refused in turn (CPU path on one and on two threads): each
// call ends in success or NFD_ERROR_OUT_OF_MEMORY, and whatever was allocated comes back.
TEST_F(HostMemory, EveryRefusedAllocationIsAnErrorWithoutLeak) {
    const Bytes bytes = read_bytes(golden_path("bunny_sdf_w16", ".nfc"));
    ASSERT_TRUE(decode(bytes, 32, 1, nullptr).complete());
    const int64_t needed = heap_.calls.load();
    ASSERT_GT(needed, 0);
    const int64_t stride = std::max<int64_t>(1, needed / 150);
    std::printf("a decode at 32 and a stream: %lld allocations, every %lld-th refused\n",
                static_cast<long long>(needed), static_cast<long long>(stride));
    for (unsigned threads : {1u, 2u}) {
        for (int64_t budget = 0; budget <= needed; budget += stride) {
            SCOPED_TRACE("threads " + std::to_string(threads) + ", allocation " +
                         std::to_string(budget));
            heap_.calls = 0;
            heap_.budget = budget;
            const Decode d = decode(bytes, 32, threads, nullptr);
            EXPECT_TRUE(out_of_memory_or_success(d.context));
            EXPECT_TRUE(out_of_memory_or_success(d.asset));
            EXPECT_TRUE(out_of_memory_or_success(d.stream));
            if (d.context == NFD_SUCCESS && d.asset == NFD_SUCCESS)
                EXPECT_TRUE(out_of_memory_or_success(d.mesh)) << d.mesh;
            EXPECT_EQ(heap_.live.load(), 0);
        }
    }
    heap_.budget = INT64_MAX;
}

TEST_F(HostMemory, ReplacedOnlyWhileNothingIsAlive) {
    nfd_context* ctx = cpu_context(1);
    ASSERT_NE(ctx, nullptr);
    EXPECT_GT(heap_.live.load(), 0);  // the handle itself
    EXPECT_EQ(nfd_set_allocator(nullptr), NFD_ERROR_INVALID_ARGUMENT);
    CountingHeap other;
    nfd_allocator hooks = other.hooks();
    EXPECT_EQ(nfd_set_allocator(&hooks), NFD_ERROR_INVALID_ARGUMENT);
    nfd_context_destroy(ctx);
    EXPECT_EQ(heap_.live.load(), 0);

    hooks.deallocate = nullptr;
    EXPECT_EQ(nfd_set_allocator(&hooks), NFD_ERROR_INVALID_ARGUMENT);
    hooks = other.hooks();
    hooks.struct_size = 4;  // shorter than any layout
    EXPECT_EQ(nfd_set_allocator(&hooks), NFD_ERROR_INVALID_ARGUMENT);
    hooks.struct_size = 0;  // `= {0}` then fields: the first layout
    ASSERT_EQ(nfd_set_allocator(&hooks), NFD_SUCCESS);
    ctx = cpu_context(1);
    EXPECT_GT(other.live.load(), 0);
    EXPECT_EQ(heap_.live.load(), 0);
    nfd_context_destroy(ctx);
    EXPECT_EQ(other.live.load(), 0);
    const nfd_allocator back = heap_.hooks();
    EXPECT_EQ(nfd_set_allocator(&back), NFD_SUCCESS);
}

}  // namespace
}  // namespace nfd::test
