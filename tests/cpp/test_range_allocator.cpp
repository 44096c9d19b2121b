// RangeAllocator (gpu/range_allocator.h): where the Vulkan layer's small buffers go in their
// shared blocks. Plain C++, so it runs without a device.
#include <gtest/gtest.h>

#include <algorithm>
#include <random>
#include <vector>

#include "gpu/range_allocator.h"

namespace nfd::test {
namespace {

using gpu::RangeAllocator;

TEST(RangeAllocator, AlignsAndFillsThePaddingFirstFit) {
    RangeAllocator ranges(4096);
    uint64_t a = 1, b = 1, c = 1;
    ASSERT_TRUE(ranges.allocate(10, 1, &a));
    EXPECT_EQ(a, 0u);
    ASSERT_TRUE(ranges.allocate(16, 256, &b));
    EXPECT_EQ(b, 256u);  // 10..256 stays free
    ASSERT_TRUE(ranges.allocate(100, 4, &c));
    EXPECT_EQ(c, 12u);   // the first free place, aligned
    uint64_t d = 0;
    EXPECT_FALSE(ranges.allocate(4096, 1, &d));
    ASSERT_TRUE(ranges.allocate(4096 - 272, 16, &d));
    EXPECT_EQ(d, 272u);
    uint64_t e = 0;
    ASSERT_TRUE(ranges.allocate(16, 1, &e));
    EXPECT_EQ(e, 112u);  // the padding left before the aligned range
    EXPECT_FALSE(ranges.empty());
}

TEST(RangeAllocator, FreedRangesMergeBackIntoOneBlock) {
    RangeAllocator ranges(1000);
    std::vector<uint64_t> at(10);
    for (uint64_t& o : at) ASSERT_TRUE(ranges.allocate(100, 1, &o));
    uint64_t none = 0;
    EXPECT_FALSE(ranges.allocate(1, 1, &none));
    for (int i : {3, 1, 2, 9, 0, 8, 5, 7, 4, 6}) ranges.free(at[size_t(i)], 100);
    EXPECT_TRUE(ranges.empty());
    uint64_t whole = 1;
    ASSERT_TRUE(ranges.allocate(1000, 1, &whole));
    EXPECT_EQ(whole, 0u);
}

// Random allocations and frees: no two live ranges overlap, each is aligned and inside the
// block, and freeing them all leaves the block whole.
TEST(RangeAllocator, RandomUseNeverOverlaps) {
    constexpr uint64_t kCapacity = 1 << 16;
    RangeAllocator ranges(kCapacity);
    std::mt19937 rng(7);
    struct Live {
        uint64_t offset, size;
    };
    std::vector<Live> live;
    int placed = 0;
    for (int step = 0; step < 20000; ++step) {
        if (!live.empty() && rng() % 3 == 0) {
            const size_t k = rng() % live.size();
            ranges.free(live[k].offset, live[k].size);
            live.erase(live.begin() + long(k));
            continue;
        }
        const uint64_t size = 1 + rng() % 2000, alignment = uint64_t(1) << (rng() % 9);
        uint64_t offset = 0;
        if (!ranges.allocate(size, alignment, &offset)) continue;
        EXPECT_EQ(offset % alignment, 0u);
        EXPECT_LE(offset + size, kCapacity);
        for (const Live& l : live)
            ASSERT_TRUE(offset + size <= l.offset || l.offset + l.size <= offset) << step;
        live.push_back({offset, size});
        ++placed;
    }
    EXPECT_GT(placed, 5000);
    EXPECT_GT(live.size(), 10u);
    std::shuffle(live.begin(), live.end(), rng);
    for (const Live& l : live) ranges.free(l.offset, l.size);
    EXPECT_TRUE(ranges.empty());
}

}  // namespace
}  // namespace nfd::test
