// The CPU path's only threading primitive: a blocking parallel loop over contiguous slices, run
// by the calling thread and by workers that the process shares (parallel.cpp).
#pragma once
#include <algorithm>
#include <atomic>
#include <cstddef>
#include <exception>
#include <thread>
#include <vector>

namespace nfd {

// Called by each thread the library starts for compute work (the pool below, queue workers, the
// Vulkan path's pipeline warmers):
// on Linux it runs under SCHED_BATCH, which keeps its share of the CPU but never preempts a
// running thread when it wakes. A render loop that submits and polls is then not pushed off its
// core by the decode it just started (bench/RESULTS.md, "Workers that do not preempt"); where the
// policy is unavailable (other systems, a sandbox refusing it) the thread runs as it was.
void run_as_background_thread();
// The same, and on Linux at the lowest priority (nice 19): for work that is needed last, such as
// a UDF's gradient pipeline on lavapipe, which should take the CPU only when the decode's own
// threads leave it (while they wait for it, at the latest).
void run_as_lowest_priority_thread();

inline unsigned resolve_thread_count(unsigned requested) {
    if (requested) return requested;
    return std::max(1u, std::thread::hardware_concurrency());
}

namespace parallel_detail {

// One parallel loop: slices are taken in turn by whichever thread asks next.
struct Loop {
    void (*run)(void* context, size_t slice);
    void* context;
    size_t slices;
    std::atomic<size_t> next{0};
    unsigned helpers = 0;  // workers inside the loop (under the pool's lock)
};

// Runs every slice of `loop`, on the caller and on up to `workers` workers; returns when all
// have run.
void run_loop(Loop* loop, unsigned workers);

}  // namespace parallel_detail

// Calls fn(slice, begin, end) over contiguous slices of [0, n), on up to `threads` threads (0 =
// hardware concurrency), each slice at least `grain` long so that small calls stay on the
// caller's thread; `slice` < resolve_thread_count(threads) indexes per-thread state (one thread
// may run several slices). A slice's exception is rethrown here. The caller takes slices too,
// so a loop completes whether or not a worker can start or is free.
template <class Fn>
void parallel_slices(size_t n, size_t grain, unsigned threads, Fn&& fn) {
    if (n == 0) return;
    const size_t slices = std::max<size_t>(
        1, std::min<size_t>(resolve_thread_count(threads), n / std::max<size_t>(grain, 1)));
    if (slices == 1) {
        fn(size_t(0), size_t(0), n);
        return;
    }
    std::vector<std::exception_ptr> errors(slices);
    auto body = [&](size_t s) {
        try {
            fn(s, n * s / slices, n * (s + 1) / slices);
        } catch (...) {
            errors[s] = std::current_exception();
        }
    };
    parallel_detail::Loop loop{[](void* context, size_t s) { (*static_cast<decltype(body)*>(context))(s); },
                               &body, slices};
    parallel_detail::run_loop(&loop, unsigned(slices - 1));
    for (const std::exception_ptr& e : errors)
        if (e) std::rethrow_exception(e);
}

// parallel_slices without the slice index: fn(begin, end).
template <class Fn>
void parallel_for(size_t n, size_t grain, unsigned threads, Fn&& fn) {
    parallel_slices(n, grain, threads, [&fn](size_t, size_t begin, size_t end) { fn(begin, end); });
}

// fn(k, begin, end) for the ranges [k * range, min(n, (k + 1) * range)) of [0, n), on threads:
// passes that count per range, then write each range's part after the ranges before.
template <class Fn>
void for_each_range(size_t n, size_t range, unsigned threads, Fn&& fn) {
    const size_t ranges = (n + range - 1) / range;
    parallel_for(ranges, 1, threads, [&](size_t begin, size_t end) {
        for (size_t k = begin; k < end; ++k) fn(k, k * range, std::min(n, (k + 1) * range));
    });
}

}  // namespace nfd
