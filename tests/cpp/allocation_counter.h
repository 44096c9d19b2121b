// The test binary's operator new and delete (allocation_counter.cpp) count what they hand out: the
// largest single request while `g_track_allocations` is set, and always the live bytes (malloc's
// usable sizes) with their peak, so a test can bound what a call allocates.
#pragma once
#include <atomic>
#include <cstddef>
#include <cstdint>

namespace nfd::test {

extern std::atomic<bool> g_track_allocations;
extern std::atomic<size_t> g_largest_allocation;
extern std::atomic<int64_t> g_live_bytes, g_peak_live_bytes;

}  // namespace nfd::test
