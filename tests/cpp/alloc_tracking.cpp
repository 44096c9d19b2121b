#include "alloc_tracking.h"

#include <cstdint>
#include <cstdlib>
#include <new>

std::atomic<bool> g_track_allocations{false};
std::atomic<size_t> g_largest_allocation{0};
std::atomic<size_t> g_fail_allocations_over{SIZE_MAX};

void* operator new(size_t size) {
    if (g_track_allocations.load(std::memory_order_relaxed)) {
        size_t seen = g_largest_allocation.load();
        while (size > seen && !g_largest_allocation.compare_exchange_weak(seen, size)) {
        }
    }
    if (size > g_fail_allocations_over.load(std::memory_order_relaxed)) throw std::bad_alloc();
    if (void* p = std::malloc(size ? size : 1)) return p;
    throw std::bad_alloc();
}
void operator delete(void* p) noexcept { std::free(p); }
void operator delete(void* p, size_t) noexcept { std::free(p); }
