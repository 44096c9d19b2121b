// Places aligned ranges inside one block of memory: the Vulkan layer's small buffers share a
// VkDeviceMemory this way (vk_context.h, Context::create_buffer), so that a decode makes a few
// device allocations rather than one per buffer. First fit over the free ranges, which are kept
// sorted and merged: a block holds tens of buffers at a time, so a linear scan is enough.
#pragma once
#include <cstdint>
#include <vector>

namespace nfd::gpu {

class RangeAllocator {
public:
    explicit RangeAllocator(uint64_t capacity) : free_{{0, capacity}}, capacity_(capacity) {}

    // A range of `size` bytes at a multiple of `alignment` (a power of two): its offset, or false
    // when no free range holds it. The padding before the offset stays free.
    bool allocate(uint64_t size, uint64_t alignment, uint64_t* offset) {
        for (size_t i = 0; i < free_.size(); ++i) {
            const Range r = free_[i];
            const uint64_t start = (r.offset + alignment - 1) & ~(alignment - 1);
            if (start < r.offset || start > r.offset + r.size || r.offset + r.size - start < size)
                continue;
            const Range before{r.offset, start - r.offset};
            const Range after{start + size, r.offset + r.size - (start + size)};
            free_.erase(free_.begin() + i);
            if (after.size) free_.insert(free_.begin() + i, after);
            if (before.size) free_.insert(free_.begin() + i, before);
            *offset = start;
            return true;
        }
        return false;
    }

    // Gives back a range that allocate() returned (the same size), merging it with its
    // neighbours.
    void free(uint64_t offset, uint64_t size) {
        size_t i = 0;
        while (i < free_.size() && free_[i].offset < offset) ++i;
        free_.insert(free_.begin() + i, Range{offset, size});
        if (i + 1 < free_.size() && free_[i].offset + free_[i].size == free_[i + 1].offset) {
            free_[i].size += free_[i + 1].size;
            free_.erase(free_.begin() + i + 1);
        }
        if (i > 0 && free_[i - 1].offset + free_[i - 1].size == free_[i].offset) {
            free_[i - 1].size += free_[i].size;
            free_.erase(free_.begin() + i);
        }
    }

    // Whether nothing is allocated.
    bool empty() const { return free_.size() == 1 && free_[0].size == capacity_; }

private:
    struct Range {
        uint64_t offset, size;
    };
    std::vector<Range> free_;  // sorted by offset, no two adjacent
    uint64_t capacity_;
};

}  // namespace nfd::gpu
