// Internal to the CPU grid (grid.cpp, grid_follow.cpp): the chunked field evaluator both use.
#pragma once
#include <algorithm>
#include <cstdint>
#include <utility>

#include "host_memory.h"
#include "network.h"
#include "parallel.h"

namespace nfd {

constexpr size_t kEvalChunk = size_t(1) << 20;  // points per evaluate call: bounds scratch

// Evaluates grid points as they are pushed, `chunk` (kEvalChunk unless given) at a time, so that
// scratch memory does not grow with the level: push(slot, xyz) queues a point, and
// `store(slot, value, gradient)` takes its result at the next flush (gradient null unless
// `gradients`). make_slice_evaluator gives one per slice of a parallel pass.
template <class Store>
class ChunkedEvaluator {
public:
    ChunkedEvaluator(const Network& net, bool gradients, unsigned threads, Store store,
                     size_t chunk = kEvalChunk)
        : net_(net), gradients_(gradients), threads_(threads), chunk_(std::max<size_t>(chunk, 1)),
          store_(std::move(store)) {}
    void push(uint32_t slot, const float xyz[3]) {
        if (slots_.empty()) reserve();
        slots_.push_back(slot);
        xyz_.insert(xyz_.end(), xyz, xyz + 3);
        if (slots_.size() == chunk_) flush();
    }
    // Evaluates what is queued; returns the number of points evaluated since construction.
    uint64_t finish() {
        flush();
        return total_;
    }

private:
    void reserve() {
        slots_.reserve(chunk_);
        xyz_.reserve(3 * chunk_);
    }
    void flush() {
        const size_t n = slots_.size();
        if (n == 0) return;
        values_.resize(n);
        grad_.resize(gradients_ ? 3 * n : 0);
        if (gradients_)
            evaluate_gradient_cpu(net_, xyz_.data(), n, values_.data(), grad_.data(), threads_);
        else
            evaluate_cpu(net_, xyz_.data(), n, values_.data(), threads_);
        net_.ball.bound(xyz_.data(), n, values_.data());  // grid values (network.h, ShapeBall)
        for (size_t k = 0; k < n; ++k) store_(slots_[k], values_[k], gradients_ ? &grad_[3 * k] : nullptr);
        total_ += n;
        slots_.clear();
        xyz_.clear();
    }
    const Network& net_;
    const bool gradients_;
    const unsigned threads_;
    const size_t chunk_;
    Store store_;
    nfd::vector<uint32_t> slots_;
    nfd::vector<float> xyz_, values_, grad_;
    uint64_t total_ = 0;
};

template <class Store>
ChunkedEvaluator<Store> make_evaluator(const Network& net, bool gradients, unsigned threads,
                                       Store store, size_t chunk = kEvalChunk) {
    return ChunkedEvaluator<Store>(net, gradients, threads, std::move(store), chunk);
}

// The evaluator of one slice of a parallel pass (parallel_slices over `threads`): one thread, the
// slice's, and its share of kEvalChunk, so that the slices' evaluators together hold what one
// evaluator over `threads` holds (evaluator_bytes).
template <class Store>
ChunkedEvaluator<Store> make_slice_evaluator(const Network& net, bool gradients, unsigned threads,
                                             Store store) {
    return make_evaluator(net, gradients, 1, std::move(store), kEvalChunk / resolve_thread_count(threads));
}

// The points one ChunkedEvaluator over `points` points holds: its queue and results at a chunk.
inline uint64_t evaluator_bytes(const Network& net, uint64_t points, bool gradients, unsigned threads) {
    if (points == 0) return 0;
    // slots_ and xyz_ are reserved at a full chunk; values_ and grad_ at the largest flush.
    const uint64_t flush = std::min<uint64_t>(points, kEvalChunk);
    return kEvalChunk * 16 + flush * (gradients ? 16 : 4) + evaluate_scratch_bytes(net, gradients, threads);
}

}  // namespace nfd
