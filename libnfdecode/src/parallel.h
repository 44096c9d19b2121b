// The CPU path's only threading primitive: a blocking parallel loop over contiguous ranges.
#pragma once
#include <algorithm>
#include <cstddef>
#include <exception>
#include <system_error>
#include <thread>
#include <vector>

namespace nfd {

inline unsigned resolve_thread_count(unsigned requested) {
    if (requested) return requested;
    return std::max(1u, std::thread::hardware_concurrency());
}

// Calls fn(slice, begin, end) over contiguous slices of [0, n), on up to `threads` threads (0 =
// hardware concurrency), each slice at least `grain` long so that small calls stay on the
// caller's thread; `slice` < resolve_thread_count(threads) indexes per-thread state. A worker's
// exception is rethrown here (std::thread would otherwise terminate the host); a thread that
// cannot be started is not an error: its slice runs on the calling thread.
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
    std::vector<std::thread> workers;
    workers.reserve(slices - 1);
    auto run = [&](size_t s) {
        try {
            fn(s, n * s / slices, n * (s + 1) / slices);
        } catch (...) {
            errors[s] = std::current_exception();
        }
    };
    for (size_t s = 1; s < slices; ++s) {
        try {
            workers.emplace_back(run, s);
        } catch (const std::system_error&) {
            run(s);
        }
    }
    run(0);
    for (std::thread& w : workers) w.join();
    for (const std::exception_ptr& e : errors)
        if (e) std::rethrow_exception(e);
}

// parallel_slices without the slice index: fn(begin, end).
template <class Fn>
void parallel_for(size_t n, size_t grain, unsigned threads, Fn&& fn) {
    parallel_slices(n, grain, threads, [&fn](size_t, size_t begin, size_t end) { fn(begin, end); });
}

}  // namespace nfd
