// The largest single heap request made while `g_track_allocations` is set (the test executable's
// operator new, alloc_tracking.cpp): lets a test check that the parser's and the stream's
// allocations stay within what the caps and the announced sizes imply, whatever a file says.
#pragma once
#include <atomic>
#include <cstddef>

extern std::atomic<bool> g_track_allocations;
extern std::atomic<size_t> g_largest_allocation;
