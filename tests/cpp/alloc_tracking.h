// The test executable's operator new (alloc_tracking.cpp) records the largest single heap request
// made while `g_track_allocations` is set, so that a test can check that the parser's and the
// stream's allocations stay within what the caps and the announced sizes imply, whatever a file
// says; throws std::bad_alloc for requests over `g_fail_allocations_over`, so that a test can
// see what an allocation failure does; and counts the live heap bytes (malloc's usable sizes) with
// their peak, so that a test can bound what a call allocates at its peak.
#pragma once
#include <atomic>
#include <cstddef>
#include <cstdint>

extern std::atomic<bool> g_track_allocations;
extern std::atomic<size_t> g_largest_allocation;
extern std::atomic<size_t> g_fail_allocations_over;  // SIZE_MAX: never
extern std::atomic<int64_t> g_live_bytes, g_peak_live_bytes;
