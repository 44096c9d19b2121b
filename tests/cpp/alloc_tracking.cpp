#include "alloc_tracking.h"

#include <cstdlib>
#include <new>

std::atomic<bool> g_track_allocations{false};
std::atomic<size_t> g_largest_allocation{0};

void* operator new(size_t size) {
    if (g_track_allocations.load(std::memory_order_relaxed)) {
        size_t seen = g_largest_allocation.load();
        while (size > seen && !g_largest_allocation.compare_exchange_weak(seen, size)) {
        }
    }
    if (void* p = std::malloc(size ? size : 1)) return p;
    throw std::bad_alloc();
}
void operator delete(void* p) noexcept { std::free(p); }
void operator delete(void* p, size_t) noexcept { std::free(p); }
