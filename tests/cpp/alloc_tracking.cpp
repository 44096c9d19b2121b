#include "alloc_tracking.h"

#include <malloc.h>

#include <cstdint>
#include <cstdlib>
#include <new>

std::atomic<bool> g_track_allocations{false};
std::atomic<size_t> g_largest_allocation{0};
std::atomic<size_t> g_fail_allocations_over{SIZE_MAX};
std::atomic<int64_t> g_live_bytes{0}, g_peak_live_bytes{0};

namespace {
template <class T>
void raise_to(std::atomic<T>& max, T value) {
    T seen = max.load();
    while (value > seen && !max.compare_exchange_weak(seen, value)) {
    }
}

void* tracked_new(size_t size) {
    if (g_track_allocations.load(std::memory_order_relaxed)) raise_to(g_largest_allocation, size);
    if (size > g_fail_allocations_over.load(std::memory_order_relaxed)) throw std::bad_alloc();
    void* p = std::malloc(size ? size : 1);
    if (!p) throw std::bad_alloc();
    raise_to(g_peak_live_bytes, g_live_bytes += int64_t(malloc_usable_size(p)));
    return p;
}

void tracked_delete(void* p) noexcept {
    if (!p) return;
    g_live_bytes -= int64_t(malloc_usable_size(p));
    std::free(p);
}
}  // namespace

// Every form that allocates from or frees to this heap, so that the live count stays balanced.
void* operator new(size_t size) { return tracked_new(size); }
void* operator new[](size_t size) { return tracked_new(size); }
void* operator new(size_t size, const std::nothrow_t&) noexcept {
    try {
        return tracked_new(size);
    } catch (...) {
        return nullptr;
    }
}
void* operator new[](size_t size, const std::nothrow_t& tag) noexcept { return operator new(size, tag); }
void operator delete(void* p) noexcept { tracked_delete(p); }
void operator delete[](void* p) noexcept { tracked_delete(p); }
void operator delete(void* p, size_t) noexcept { tracked_delete(p); }
void operator delete[](void* p, size_t) noexcept { tracked_delete(p); }
void operator delete(void* p, const std::nothrow_t&) noexcept { tracked_delete(p); }
void operator delete[](void* p, const std::nothrow_t&) noexcept { tracked_delete(p); }
