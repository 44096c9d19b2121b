// nfd_set_allocator's hooks (host_memory.h). The hooks are read on every allocation, from any
// thread, and written only while no allocation is live, when no call of the library runs (the
// header's contract): an atomic pointer to the installed copy is all the synchronisation needed.
#include "host_memory.h"

#include <atomic>

#include "options.h"

namespace nfd {
namespace {

struct Hooks {
    void* (*allocate)(void* user, size_t size);
    void (*deallocate)(void* user, void* address);
    void* user;
};
Hooks g_installed;
std::atomic<const Hooks*> g_hooks{nullptr};  // nullptr: operator new and delete
std::atomic<int64_t> g_live{0};              // allocations not yet freed

}  // namespace

void* host_allocate_or_null(size_t bytes) noexcept {
    if (bytes == 0) bytes = 1;  // the hooks are never asked for 0 bytes
    const Hooks* hooks = g_hooks.load(std::memory_order_acquire);
    void* p = hooks ? hooks->allocate(hooks->user, bytes) : ::operator new(bytes, std::nothrow);
    if (p) g_live.fetch_add(1, std::memory_order_relaxed);
    return p;
}

void* host_allocate(size_t bytes) {
    void* p = host_allocate_or_null(bytes);
    if (!p) throw std::bad_alloc();
    return p;
}

void host_deallocate(void* address) noexcept {
    if (!address) return;
    g_live.fetch_sub(1, std::memory_order_relaxed);
    const Hooks* hooks = g_hooks.load(std::memory_order_acquire);
    if (hooks)
        hooks->deallocate(hooks->user, address);
    else
        ::operator delete(address);
}

nfd_result set_host_allocator(const nfd_allocator* allocator) noexcept {
    nfd_allocator a;
    if (read_options(allocator, sizeof(nfd_allocator), &a) != NFD_SUCCESS ||
        (allocator && (!a.allocate || !a.deallocate)))
        return NFD_ERROR_INVALID_ARGUMENT;
    if (g_live.load(std::memory_order_acquire) != 0) return NFD_ERROR_INVALID_ARGUMENT;
    g_hooks.store(nullptr, std::memory_order_release);
    if (!allocator) return NFD_SUCCESS;
    g_installed = Hooks{a.allocate, a.deallocate, a.user};
    g_hooks.store(&g_installed, std::memory_order_release);
    return NFD_SUCCESS;
}

}  // namespace nfd
