// Host memory (nfdecode.h, nfd_set_allocator): what the library allocates in proportion to its
// input (handles, networks, grids, meshes, voxels, stream buffers, evaluator batches, the brotli
// decoder's state) goes through host_allocate, which calls the host's functions when it installed
// some and operator new otherwise. The allocations live at any moment are counted, so that the
// functions are only replaced when nothing the previous ones allocated remains.
#pragma once
#include <cstddef>
#include <cstdint>
#include <new>
#include <type_traits>
#include <utility>
#include <vector>

#include "nfdecode/nfdecode.h"

namespace nfd {

void* host_allocate(size_t bytes);                     // std::bad_alloc when it fails
void* host_allocate_or_null(size_t bytes) noexcept;
void host_deallocate(void* address) noexcept;          // NULL: nothing
nfd_result set_host_allocator(const nfd_allocator* allocator) noexcept;

// The standard containers' allocator over host_allocate. Stateless: every instance is equal.
template <class T>
struct HostAllocator {
    using value_type = T;
    static_assert(alignof(T) <= 16, "the hooks promise 16-byte alignment");
    HostAllocator() noexcept = default;
    template <class U>
    HostAllocator(const HostAllocator<U>&) noexcept {}
    T* allocate(size_t n) {
        if (n > SIZE_MAX / sizeof(T)) throw std::bad_array_new_length();
        return static_cast<T*>(host_allocate(n * sizeof(T)));
    }
    void deallocate(T* p, size_t) noexcept { host_deallocate(p); }
};
template <class T, class U>
bool operator==(const HostAllocator<T>&, const HostAllocator<U>&) noexcept { return true; }
template <class T, class U>
bool operator!=(const HostAllocator<T>&, const HostAllocator<U>&) noexcept { return false; }

template <class T>
using vector = std::vector<T, HostAllocator<T>>;

// The same allocator, but containers default-initialise new elements (vector(n) and resize(n)
// leave a trivial type's bytes as they are): for large arrays that a parallel pass then fills.
template <class T>
struct HostAllocatorNoInit : HostAllocator<T> {
    template <class U>
    struct rebind {
        using other = HostAllocatorNoInit<U>;
    };
    HostAllocatorNoInit() noexcept = default;
    template <class U>
    HostAllocatorNoInit(const HostAllocatorNoInit<U>&) noexcept {}
    template <class U>
    void construct(U* p) noexcept(std::is_nothrow_default_constructible<U>::value) {
        ::new (static_cast<void*>(p)) U;
    }
    template <class U, class... Args>
    void construct(U* p, Args&&... args) {
        ::new (static_cast<void*>(p)) U(std::forward<Args>(args)...);
    }
};
template <class T>
using uninitialized_vector = std::vector<T, HostAllocatorNoInit<T>>;

// A base of the library's heap objects (the API's handles): their new and delete use the hooks.
struct HostAllocated {
    static void* operator new(size_t bytes) { return host_allocate(bytes); }
    static void* operator new(size_t bytes, const std::nothrow_t&) noexcept {
        return host_allocate_or_null(bytes);
    }
    static void operator delete(void* address) noexcept { host_deallocate(address); }
    static void operator delete(void* address, const std::nothrow_t&) noexcept {
        host_deallocate(address);
    }
};

}  // namespace nfd
