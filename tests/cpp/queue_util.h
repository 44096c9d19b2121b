// What the queue tests share (test_queue.cpp, test_queue_stream.cpp): contexts, queues and assets
// made in one line, jobs held at a Gate or recorded by Calls, and byte-for-byte mesh comparison.
#pragma once
#include <gtest/gtest.h>
#include <nfdecode/nfdecode.h>

#include <atomic>
#include <cstring>
#include <future>
#include <mutex>
#include <thread>
#include <vector>

#include "test_util.h"

namespace nfd::test {
namespace {

constexpr uint64_t kForever = UINT64_MAX;

inline bool is_final(nfd_job_status s) {
    return s == NFD_JOB_DONE || s == NFD_JOB_FAILED || s == NFD_JOB_CANCELLED;
}

// A callback that holds its worker until the test opens the gate: the jobs queued behind stay
// QUEUED meanwhile, whatever the speed of the machine.
struct Gate {
    std::promise<void> opened;
    std::shared_future<void> is_open = opened.get_future().share();
    std::atomic<int> calls{0};
    void open() { opened.set_value(); }
    // Options of a job whose callback holds its worker at this gate.
    nfd_job_options job_options(int32_t priority = 0, uint32_t mesh_levels = 0) {
        nfd_job_options o = {};
        o.struct_size = sizeof o;
        o.priority = priority;
        o.callback = hold;
        o.user_data = this;
        o.mesh_levels = mesh_levels;
        return o;
    }
    static void hold(nfd_job*, nfd_job_status, void* user) {
        auto* gate = static_cast<Gate*>(user);
        ++gate->calls;
        gate->is_open.wait();
    }
};

// Records every callback: which job (user index), its status, on which thread.
struct Calls {
    std::mutex mutex;
    std::vector<int> order;
    std::vector<nfd_job_status> statuses;
    std::vector<std::thread::id> threads;
    struct Entry {
        Calls* calls;
        int index;
    };
    std::vector<Entry> entries;
    explicit Calls(int n) {
        for (int i = 0; i < n; ++i) entries.push_back({this, i});
    }
    static void record(nfd_job*, nfd_job_status status, void* user) {
        auto* e = static_cast<Entry*>(user);
        std::lock_guard<std::mutex> lock(e->calls->mutex);
        e->calls->order.push_back(e->index);
        e->calls->statuses.push_back(status);
        e->calls->threads.push_back(std::this_thread::get_id());
    }
    nfd_job_options options(int index, int32_t priority = 0) {
        nfd_job_options o = {};
        o.struct_size = sizeof o;
        o.priority = priority;
        o.callback = record;
        o.user_data = &entries[size_t(index)];
        return o;
    }
    size_t count() {
        std::lock_guard<std::mutex> lock(mutex);
        return order.size();
    }
};

inline nfd_mesh_options mesh_options(uint32_t resolution) {
    nfd_mesh_options mo = {};
    mo.struct_size = sizeof mo;
    mo.resolution = resolution;
    return mo;
}

inline nfd_asset* make_asset(const Bytes& bytes) {
    nfd_asset* a = nullptr;
    EXPECT_EQ(nfd_asset_create(bytes.data(), bytes.size(), &a), NFD_SUCCESS);
    return a;
}

inline ::testing::AssertionResult same_mesh(const nfd_mesh* a, const nfd_mesh* b) {
    nfd_mesh_data x, y;
    if (nfd_mesh_get_data(a, &x) != NFD_SUCCESS || nfd_mesh_get_data(b, &y) != NFD_SUCCESS)
        return ::testing::AssertionFailure() << "no mesh";
    if (x.vertex_count != y.vertex_count || x.triangle_count != y.triangle_count)
        return ::testing::AssertionFailure() << x.vertex_count << "/" << x.triangle_count << " vs "
                                             << y.vertex_count << "/" << y.triangle_count;
    const size_t v = 3 * x.vertex_count * sizeof(float);
    const size_t t = 3 * x.triangle_count * sizeof(uint32_t);
    if ((v && (std::memcmp(x.positions, y.positions, v) || std::memcmp(x.normals, y.normals, v))) ||
        (t && std::memcmp(x.indices, y.indices, t)))
        return ::testing::AssertionFailure() << "bytes differ";
    const float *ca = nullptr, *cb = nullptr;
    nfd_mesh_get_colours(a, &ca);
    nfd_mesh_get_colours(b, &cb);
    if (!ca != !cb || (ca && v && std::memcmp(ca, cb, v)))
        return ::testing::AssertionFailure() << "colours differ";
    return ::testing::AssertionSuccess();
}

inline nfd_context* make_context(nfd_device_kind kind, uint32_t cpu_threads = 2) {
    nfd_context_options o = {};
    o.device = kind;
    o.cpu_threads = cpu_threads;
    nfd_context* ctx = nullptr;
    return nfd_context_create(&o, &ctx) == NFD_SUCCESS ? ctx : nullptr;
}

inline nfd_queue* make_queue(nfd_context* ctx, uint32_t workers, uint64_t host_budget = 0) {
    nfd_queue_options o = {};
    o.struct_size = sizeof o;
    o.worker_threads = workers;
    o.host_budget_bytes = host_budget;
    nfd_queue* q = nullptr;
    EXPECT_EQ(nfd_queue_create(ctx, &o, &q), NFD_SUCCESS);
    return q;
}

// A small closed blob away from the origin (CPU decodes in milliseconds).
inline Bytes blob(float scale) {
    const float center[3] = {0.5f * scale, -1.0f, 2.0f};
    return geom_file(closed_blob(scale, center));
}

}  // namespace
}  // namespace nfd::test
