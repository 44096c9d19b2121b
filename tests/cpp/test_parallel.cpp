// The CPU path's parallel loops (parallel.h, parallel.cpp): every index once, slice indices for
// per-thread state, exceptions carried back, nested loops and loops in a forked child that
// complete, and a decode whose passes split across threads giving the one-thread mesh.
#include <gtest/gtest.h>

#include <sched.h>
#include <sys/resource.h>
#include <sys/syscall.h>
#include <sys/wait.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <stdexcept>
#include <thread>
#include <vector>

#include "extract.h"
#include "parallel.h"
#include "test_util.h"

namespace nfd::test {
namespace {

TEST(Parallel, SlicesCoverTheRangeOnceWithTheirIndices) {
    for (unsigned threads : {1u, 2u, 3u, 8u}) {
        const size_t n = 100003;
        std::vector<std::atomic<int>> seen(n);
        std::vector<std::atomic<int>> slice_used(threads);
        parallel_slices(n, 1000, threads, [&](size_t slice, size_t begin, size_t end) {
            ASSERT_LT(slice, threads);
            ++slice_used[slice];
            for (size_t i = begin; i < end; ++i) ++seen[i];
        });
        for (size_t i = 0; i < n; ++i) ASSERT_EQ(seen[i].load(), 1) << i << ", " << threads << " threads";
        for (unsigned s = 0; s < threads; ++s) EXPECT_EQ(slice_used[s].load(), 1) << s;
    }
    // Below two grains: one slice, on the caller's thread.
    const std::thread::id caller = std::this_thread::get_id();
    parallel_slices(1999, 1000, 8, [&](size_t slice, size_t begin, size_t end) {
        EXPECT_EQ(slice, 0u);
        EXPECT_EQ(begin, 0u);
        EXPECT_EQ(end, 1999u);
        EXPECT_EQ(std::this_thread::get_id(), caller);
    });
}

TEST(Parallel, ASlicesExceptionReachesTheCaller) {
    std::atomic<size_t> ran{0};
    EXPECT_THROW(parallel_for(8000, 1000, 8,
                              [&](size_t begin, size_t) {
                                  ++ran;
                                  if (begin == 3000) throw std::runtime_error("slice 3");
                              }),
                 std::runtime_error);
    EXPECT_EQ(ran.load(), 8u);  // the other slices still ran
}

TEST(Parallel, NestedLoopsComplete) {
    // Each outer slice runs loops of its own, more than there are workers: the callers take the
    // slices no worker is free for.
    std::atomic<size_t> total{0};
    parallel_for(64, 1, 16, [&](size_t begin, size_t end) {
        for (size_t i = begin; i < end; ++i)
            parallel_for(4096, 64, 16, [&](size_t b, size_t e) { total += e - b; });
    });
    EXPECT_EQ(total.load(), 64u * 4096u);
}

// A fork copies none of the workers, and may come while one holds the pool's lock: the child
// still completes its loops, a whole decode included (on its calling thread: it starts no
// worker). Several forks while another thread keeps the workers busy, so that some land mid-loop.
TEST(Parallel, LoopsCompleteInAForkedChild) {
    const Geometry g = parse_or_throw(read_bytes(golden_path("bunny_sdf_w16", ".nfc")));
    MeshData parent_mesh;
    ASSERT_EQ(extract_mesh_cpu(g, 128, &parent_mesh, nullptr, 4), NFD_SUCCESS);  // the workers exist
    // The child's exit status: 0 its mesh is the parent's, 1 it differs, -1 it did not finish
    // within 20 s (killed).
    auto fork_and_decode = [&]() -> int {
        const pid_t child = fork();
        if (child < 0) return -2;
        if (child == 0) {
            MeshData mesh;
            const bool same = extract_mesh_cpu(g, 128, &mesh, nullptr, 4) == NFD_SUCCESS &&
                              mesh.indices == parent_mesh.indices &&
                              mesh.positions == parent_mesh.positions;
            _exit(same ? 0 : 1);
        }
        int status = 0;
        for (int waited = 0; waited < 200; ++waited) {
            if (waitpid(child, &status, WNOHANG) == child)
                return WIFEXITED(status) ? WEXITSTATUS(status) : -3;
            std::this_thread::sleep_for(std::chrono::milliseconds(100));
        }
        kill(child, SIGKILL);
        waitpid(child, &status, 0);
        return -1;
    };
    std::atomic<bool> stop{false};
    std::thread busy([&] {
        while (!stop) parallel_for(4096, 64, 4, [](size_t, size_t) {});
    });
    std::vector<int> results;
    for (int round = 0; round < 5; ++round) results.push_back(fork_and_decode());
    stop = true;
    busy.join();
    for (int r : results) EXPECT_EQ(r, 0) << "-1: the child's decode did not finish; 1: its mesh differs";
}

#ifdef SCHED_BATCH
// The pool's workers run under SCHED_BATCH (run_as_background_thread); the caller's thread keeps
// its own policy. Slice 0 waits until slice 1 has started, so the two run on two threads, one of
// them at least a worker (the caller may run either, or none).
TEST(Parallel, WorkersRunAsBackgroundThreads) {
    const int caller_policy = sched_getscheduler(0);
    const std::thread::id caller = std::this_thread::get_id();
    std::atomic<bool> second_started{false};
    std::atomic<int> worker_policy{-1};
    parallel_slices(2, 1, 2, [&](size_t slice, size_t, size_t) {
        if (std::this_thread::get_id() != caller) worker_policy = sched_getscheduler(0);
        if (slice == 0) {
            while (!second_started.load()) std::this_thread::yield();
        } else {
            second_started = true;
        }
    });
    EXPECT_EQ(worker_policy.load(), SCHED_BATCH);
    EXPECT_EQ(sched_getscheduler(0), caller_policy);
}
#endif

#ifdef __linux__
// run_as_lowest_priority_thread lowers its own thread alone to nice 19 (Linux's nice is per
// thread), under SCHED_BATCH where the sandbox allows it.
TEST(Parallel, LowestPriorityThreadLowersItselfAlone) {
    const int caller_nice = getpriority(PRIO_PROCESS, id_t(syscall(SYS_gettid)));
    int nice = -100;
    std::thread([&] {
        run_as_lowest_priority_thread();
        nice = getpriority(PRIO_PROCESS, id_t(syscall(SYS_gettid)));
    }).join();
    EXPECT_EQ(nice, 19);
    EXPECT_EQ(getpriority(PRIO_PROCESS, id_t(syscall(SYS_gettid))), caller_nice);
}
#endif

// At 256 the flood's waves, the region, the level collection and a UDF's gradient corners all
// split across threads (their grains are a few thousand cells): the mesh and the evaluation
// counts are the one-thread decode's, whatever the thread count.
TEST(Parallel, ThreadCountChangesNoMeshWhereThePassesSplit) {
    for (const char* name : {"bunny_sdf_w32", "tshirt_udf_w16"}) {
        const Geometry g = parse_or_throw(read_bytes(golden_path(name, ".nfc")));
        MeshData one;
        ExtractStats one_stats;
        ASSERT_EQ(extract_mesh_cpu(g, 256, &one, &one_stats, 1), NFD_SUCCESS) << name;
        ASSERT_GT(one.triangle_count(), 10000u) << name;
        for (unsigned threads : {2u, 5u}) {
            MeshData mesh;
            ExtractStats stats;
            ASSERT_EQ(extract_mesh_cpu(g, 256, &mesh, &stats, threads), NFD_SUCCESS) << name;
            EXPECT_EQ(mesh.indices, one.indices) << name << ", " << threads << " threads";
            EXPECT_EQ(mesh.positions, one.positions) << name << ", " << threads << " threads";
            EXPECT_EQ(mesh.normals, one.normals) << name << ", " << threads << " threads";
            EXPECT_EQ(stats.points_evaluated, one_stats.points_evaluated) << name;
            EXPECT_EQ(stats.gradients_evaluated, one_stats.gradients_evaluated) << name;
        }
    }
}

}  // namespace
}  // namespace nfd::test
