// The asynchronous queue (nfdecode.h, "Asynchronous queue"): results identical to
// nfd_mesh_extract, priority order, cancel and destroy in every status, the memory budget,
// callbacks, waits and arguments. No test depends on timing: where a job must stay in a status,
// a worker is held inside a callback (a Gate) until the test opens it. Run under ThreadSanitizer
// and AddressSanitizer by scripts/sanitize.sh.
#include <gtest/gtest.h>
#include <nfdecode/nfdecode.h>
#include <sched.h>

#include <atomic>
#include <cstring>
#include <future>
#include <mutex>
#include <chrono>
#include <thread>
#include <vector>

#include "extract.h"
#include "extract_work.h"
#include "grid.h"
#include "queue.h"
#include "queue_util.h"
#include "test_util.h"

namespace nfd::test {
namespace {

// The host bytes the queue reserves for the first step of a CPU job (extract_work.h): the whole
// job under 64 cells (a ladder of one level).
uint64_t first_step_host(const Bytes& bytes, uint32_t resolution) {
    const uint32_t coarse = cells_at_level(resolution, refinement_levels(resolution));
    return extract_bytes_bound(parse_or_throw(bytes), coarse, false).host;
}

// The largest host reservation of a CPU job, its last step's (each step's adds to the last):
// the job's steps run here as a worker runs them.
uint64_t job_host_reservation(const Bytes& bytes, uint32_t resolution, unsigned cpu_threads) {
    ExtractWork work(parse_or_throw(bytes), std::nullopt, resolution, 1u, nullptr, cpu_threads);
    for (;;) {
        const uint64_t reserved = work.next_step_bytes().host;
        StepResult step;
        EXPECT_EQ(work.step(&step), NFD_SUCCESS);
        if (step.finished) return reserved;
    }
}

// A job whose extraction takes long enough to be seen RUNNING, and then cancelled, by a test that
// polls for it: the UDF golden vector at 128 on one CPU thread takes 0.4 s or more (40 s under
// ThreadSanitizer), while a poll and the cancel that follows it are microseconds apart.
Bytes slow_asset() { return read_bytes(golden_path("tshirt_udf_w16", ".nfc")); }
constexpr uint32_t kSlowResolution = 128;

// Waits (polling, no deadline) until the job leaves the statuses before `status`.
nfd_job_status poll_until_at_least(nfd_job* job, nfd_job_status status) {
    nfd_job_status s;
    while ((s = nfd_job_poll(job)) < status) std::this_thread::yield();
    return s;
}

// Ten assets at once, or more: every golden vector (SDF, UDF, with colour, geo-referenced) and
// synthetic ones, one with an empty surface, at several resolutions; every mesh is
// nfd_mesh_extract's on the same context, byte for byte (colours included), and every callback
// fires once, DONE, on a worker.
void ten_assets_match_mesh_extract(nfd_context* ctx, uint32_t workers) {
    std::vector<Bytes> files;
    for (const std::string& name : golden_names())
        files.push_back(read_bytes(golden_path(name, ".nfc")));
    ASSERT_GE(files.size(), 6u);
    GeomSpec positive = closed_blob();
    positive.levels.back() = 20000;  // f > 0 everywhere: an empty mesh
    files.push_back(geom_file(positive));
    for (float scale : {1.0f, 2.0f, 0.5f})
        if (files.size() < 10) files.push_back(blob(scale));
    ASSERT_GE(files.size(), 10u);
    const size_t n = files.size();
    const uint32_t cycle[10] = {48, 40, 48, 40, 48, 32, 64, 33, 96, 16};
    std::vector<uint32_t> resolutions;
    for (size_t i = 0; i < n; ++i) resolutions.push_back(cycle[i % 10]);

    std::vector<nfd_asset*> assets;
    std::vector<nfd_mesh*> expected;
    for (size_t i = 0; i < files.size(); ++i) {
        assets.push_back(make_asset(files[i]));
        const nfd_mesh_options mo = mesh_options(resolutions[i]);
        nfd_mesh* m = nullptr;
        ASSERT_EQ(nfd_mesh_extract(ctx, assets[i], &mo, &m), NFD_SUCCESS);
        expected.push_back(m);
    }

    Calls calls{int(n)};
    nfd_queue* q = make_queue(ctx, workers);
    std::vector<nfd_job*> jobs(n);
    for (int i = 0; i < int(n); ++i) {
        const nfd_mesh_options mo = mesh_options(resolutions[i]);
        const nfd_job_options jo = calls.options(i);
        ASSERT_EQ(nfd_queue_submit(q, assets[size_t(i)], &mo, &jo, &jobs[size_t(i)]), NFD_SUCCESS);
    }
    for (nfd_asset* a : assets) nfd_asset_destroy(a);  // the queue keeps what it needs
    for (int i = 0; i < int(n); ++i) {
        SCOPED_TRACE(i);
        ASSERT_EQ(nfd_job_wait(jobs[size_t(i)], kForever), NFD_JOB_DONE);
        nfd_mesh* m = nullptr;
        ASSERT_EQ(nfd_job_take_mesh(jobs[size_t(i)], &m), NFD_SUCCESS);
        EXPECT_TRUE(same_mesh(m, expected[size_t(i)]));
        nfd_mesh* again = reinterpret_cast<nfd_mesh*>(0x1);
        EXPECT_EQ(nfd_job_take_mesh(jobs[size_t(i)], &again), NFD_SUCCESS);
        EXPECT_EQ(again, nullptr);  // taken
        nfd_mesh_destroy(m);
        nfd_mesh_destroy(expected[size_t(i)]);
    }
    nfd_queue_stats st;
    ASSERT_EQ(nfd_queue_get_stats(q, &st), NFD_SUCCESS);
    EXPECT_EQ(st.jobs_submitted, n);
    EXPECT_EQ(st.jobs_done, n);
    EXPECT_EQ(st.jobs_failed + st.jobs_cancelled, 0u);
    EXPECT_EQ(st.reserved_host_bytes + st.reserved_device_bytes, 0u);
    EXPECT_GT(st.peak_reserved_host_bytes, 0u);
    for (nfd_job* j : jobs) nfd_job_destroy(j);
    nfd_queue_destroy(q);  // every callback has run once the workers are joined
    EXPECT_EQ(calls.count(), n);
    std::vector<int> seen = calls.order;
    std::sort(seen.begin(), seen.end());
    for (int i = 0; i < int(n); ++i) EXPECT_EQ(seen[size_t(i)], i);
    for (nfd_job_status s : calls.statuses) EXPECT_EQ(s, NFD_JOB_DONE);
    for (std::thread::id t : calls.threads) EXPECT_NE(t, std::this_thread::get_id());
}

TEST(Queue, TenAssetsAtOnceMatchMeshExtractCpu) {
    nfd_context* ctx = make_context(NFD_DEVICE_CPU);
    ASSERT_NE(ctx, nullptr);
    ten_assets_match_mesh_extract(ctx, 3);
    nfd_context_destroy(ctx);
}

// A context on the Vulkan device (lavapipe here); skips without one unless NFD_REQUIRE_VULKAN.
struct QueueVulkan : ::testing::Test {
    nfd_context* ctx = nullptr;
    void SetUp() override {
        ctx = make_context(NFD_DEVICE_VULKAN);
        skip_without_vulkan(ctx ? "" : "no Vulkan device");
    }
    void TearDown() override { nfd_context_destroy(ctx); }
};

#if NFD_WITH_VULKAN
TEST_F(QueueVulkan, TenAssetsAtOnceMatchMeshExtractVulkan) {
    ten_assets_match_mesh_extract(ctx, 4);  // four jobs at once, each with its own batches
}

// Two workers on a Vulkan context: while one job's worker is held in its first level's
// callback, with that job's extraction alive on the device, a second job runs to the end on the
// other worker, and then the first finishes too, both meshes those of nfd_mesh_extract.
TEST_F(QueueVulkan, JobsRunOnTwoWorkersAtOnceVulkan) {
    nfd_asset* a = make_asset(blob(1.0f));
    nfd_queue* q = make_queue(ctx, 2);
    const nfd_mesh_options mo = mesh_options(64);
    nfd_mesh* expected = nullptr;
    ASSERT_EQ(nfd_mesh_extract(ctx, a, &mo, &expected), NFD_SUCCESS);
    Gate gate;
    const nfd_job_options held = gate.job_options(1, 0b11);  // 32 and 64: a callback at 32
    nfd_job *first = nullptr, *second = nullptr;
    ASSERT_EQ(nfd_queue_submit(q, a, &mo, &held, &first), NFD_SUCCESS);
    while (gate.calls.load() == 0) std::this_thread::sleep_for(std::chrono::milliseconds(1));
    ASSERT_EQ(nfd_queue_submit(q, a, &mo, nullptr, &second), NFD_SUCCESS);
    EXPECT_EQ(nfd_job_wait(second, kForever), NFD_JOB_DONE);
    EXPECT_EQ(nfd_job_poll(first), NFD_JOB_RUNNING);  // still held
    gate.open();
    EXPECT_EQ(nfd_job_wait(first, kForever), NFD_JOB_DONE);
    for (nfd_job* j : {first, second}) {
        nfd_mesh* m = nullptr;
        ASSERT_EQ(nfd_job_take_mesh(j, &m), NFD_SUCCESS);
        EXPECT_TRUE(same_mesh(m, expected));
        nfd_mesh_destroy(m);
        nfd_job_destroy(j);
    }
    nfd_mesh_destroy(expected);
    nfd_queue_destroy(q);
    nfd_asset_destroy(a);
}
#endif

// A CPU context, a small blob's asset and a one-worker queue, destroyed in that order's reverse.
struct QueueOnBlob : ::testing::Test {
    nfd_context* ctx = make_context(NFD_DEVICE_CPU);
    nfd_asset* a = make_asset(blob(1.0f));
    nfd_queue* q = make_queue(ctx, 1);
    void TearDown() override {
        nfd_queue_destroy(q);
        nfd_asset_destroy(a);
        nfd_context_destroy(ctx);
    }
};

// One worker, held by a first job's callback while the others are queued: they then run by
// priority, higher first, submission order among equals.
TEST_F(QueueOnBlob, PriorityOrderThenSubmissionOrder) {
    const nfd_mesh_options mo = mesh_options(16);
    Gate gate;
    // Runs first even if the worker had not taken it yet.
    const nfd_job_options hold = gate.job_options(INT32_MAX);
    nfd_job* first = nullptr;
    ASSERT_EQ(nfd_queue_submit(q, a, &mo, &hold, &first), NFD_SUCCESS);

    const int32_t priorities[] = {1, 5, INT32_MIN, 5, 3, -2, 5, 1};
    const int expected_order[] = {1, 3, 6, 4, 0, 7, 5, 2};
    Calls calls(8);
    std::vector<nfd_job*> jobs(8);
    for (int i = 0; i < 8; ++i) {
        const nfd_job_options jo = calls.options(i, priorities[i]);
        ASSERT_EQ(nfd_queue_submit(q, a, &mo, &jo, &jobs[size_t(i)]), NFD_SUCCESS);
        EXPECT_EQ(nfd_job_poll(jobs[size_t(i)]), NFD_JOB_QUEUED);
    }
    gate.open();
    for (nfd_job* j : jobs) EXPECT_EQ(nfd_job_wait(j, kForever), NFD_JOB_DONE);
    EXPECT_EQ(calls.order, std::vector<int>(std::begin(expected_order), std::end(expected_order)));
    EXPECT_EQ(gate.calls.load(), 1);
    for (nfd_job* j : jobs) nfd_job_destroy(j);
    nfd_job_destroy(first);
}

// Queued: cancelled at once, its callback on the cancelling thread, nothing left reserved.
TEST_F(QueueOnBlob, CancelQueuedJob) {
    const nfd_mesh_options mo = mesh_options(16);
    Gate gate;
    const nfd_job_options hold = gate.job_options(1);
    nfd_job *first = nullptr, *job = nullptr;
    ASSERT_EQ(nfd_queue_submit(q, a, &mo, &hold, &first), NFD_SUCCESS);
    Calls calls(1);
    const nfd_job_options jo = calls.options(0);
    ASSERT_EQ(nfd_queue_submit(q, a, &mo, &jo, &job), NFD_SUCCESS);
    nfd_mesh* m = reinterpret_cast<nfd_mesh*>(0x1);
    EXPECT_EQ(nfd_job_take_mesh(job, &m), NFD_ERROR_NOT_READY);
    EXPECT_EQ(m, nullptr);
    EXPECT_EQ(nfd_job_cancel(job), NFD_SUCCESS);
    EXPECT_EQ(nfd_job_poll(job), NFD_JOB_CANCELLED);
    ASSERT_EQ(calls.count(), 1u);
    EXPECT_EQ(calls.statuses[0], NFD_JOB_CANCELLED);
    EXPECT_EQ(calls.threads[0], std::this_thread::get_id());
    EXPECT_EQ(nfd_job_take_mesh(job, &m), NFD_ERROR_CANCELLED);
    EXPECT_EQ(nfd_job_cancel(job), NFD_SUCCESS);  // final: stays as it is, no second callback
    EXPECT_EQ(calls.count(), 1u);
    gate.open();
    EXPECT_EQ(nfd_job_wait(first, kForever), NFD_JOB_DONE);
    nfd_queue_stats st;
    nfd_queue_get_stats(q, &st);
    EXPECT_EQ(st.jobs_cancelled, 1u);
    nfd_job_destroy(job);
    nfd_job_destroy(first);
}

// Running: the step completes, the job ends CANCELLED at that boundary and its mesh is freed
// (the ASan run checks that nothing leaks); the queue carries on with the next job.
TEST(Queue, CancelRunningJob) {
    nfd_context* ctx = make_context(NFD_DEVICE_CPU, 1);
    nfd_asset* slow = make_asset(slow_asset());
    nfd_asset* small = make_asset(blob(1.0f));
    nfd_queue* q = make_queue(ctx, 1);
    const nfd_mesh_options big = mesh_options(kSlowResolution), tiny = mesh_options(16);
    Calls calls(2);
    const nfd_job_options jo0 = calls.options(0), jo1 = calls.options(1);
    nfd_job *job = nullptr, *next = nullptr;
    ASSERT_EQ(nfd_queue_submit(q, slow, &big, &jo0, &job), NFD_SUCCESS);
    ASSERT_EQ(nfd_queue_submit(q, small, &tiny, &jo1, &next), NFD_SUCCESS);
    ASSERT_EQ(poll_until_at_least(job, NFD_JOB_RUNNING), NFD_JOB_RUNNING);
    EXPECT_EQ(nfd_job_cancel(job), NFD_SUCCESS);
    EXPECT_EQ(nfd_job_wait(job, kForever), NFD_JOB_CANCELLED);
    nfd_mesh* m = nullptr;
    EXPECT_EQ(nfd_job_take_mesh(job, &m), NFD_ERROR_CANCELLED);
    EXPECT_EQ(m, nullptr);
    EXPECT_EQ(nfd_job_wait(next, kForever), NFD_JOB_DONE);
    nfd_queue_destroy(q);
    ASSERT_EQ(calls.count(), 2u);
    EXPECT_EQ(calls.order, (std::vector<int>{0, 1}));
    EXPECT_EQ(calls.statuses[0], NFD_JOB_CANCELLED);
    EXPECT_NE(calls.threads[0], std::this_thread::get_id());  // the worker ended it
    nfd_job_destroy(job);
    nfd_job_destroy(next);
    nfd_asset_destroy(slow);
    nfd_asset_destroy(small);
    nfd_context_destroy(ctx);
}

// nfd_job_destroy in every status: queued, waiting for memory, running, done with an untaken mesh,
// failed, cancelled. No callback of a destroyed job fires afterwards; the queue is then empty.
TEST(Queue, DestroyJobInEveryStatus) {
    nfd_context* ctx = make_context(NFD_DEVICE_CPU, 1);
    const Bytes slow_bytes = slow_asset(), small_bytes = blob(1.0f);
    nfd_asset* slow = make_asset(slow_bytes);
    nfd_asset* small = make_asset(small_bytes);
    const nfd_mesh_options big = mesh_options(kSlowResolution), tiny = mesh_options(16);
    const uint64_t slow_first = first_step_host(slow_bytes, kSlowResolution);
    const uint64_t small_bound = first_step_host(small_bytes, 16);
    // Two workers; the running slow job, held in its first level's callback, keeps its first
    // step's reservation, which leaves no room for a second slow one.
    nfd_queue* q = make_queue(ctx, 2, slow_first + small_bound);
    Calls calls(6);

    nfd_job *done = nullptr, *failed = nullptr, *cancelled = nullptr;
    const nfd_job_options jo0 = calls.options(0), jo1 = calls.options(1), jo2 = calls.options(2);
    ASSERT_EQ(nfd_queue_submit(q, small, &tiny, &jo0, &done), NFD_SUCCESS);
    ASSERT_EQ(nfd_job_wait(done, kForever), NFD_JOB_DONE);  // its mesh stays untaken
    // Failed: a job whose second level's reservation exceeds the whole budget.
    const nfd_mesh_options huge = mesh_options(1024);
    ASSERT_EQ(nfd_queue_submit(q, slow, &huge, &jo1, &failed), NFD_SUCCESS);
    ASSERT_EQ(nfd_job_wait(failed, kForever), NFD_JOB_FAILED);
    ASSERT_EQ(nfd_queue_submit(q, small, &tiny, &jo2, &cancelled), NFD_SUCCESS);
    nfd_job_cancel(cancelled);
    ASSERT_TRUE(is_final(nfd_job_wait(cancelled, kForever)));

    nfd_job *running = nullptr, *waiting = nullptr, *queued = nullptr;
    const nfd_job_options jo4 = calls.options(4), jo5 = calls.options(5);
    Gate gate;
    const nfd_job_options hold = gate.job_options(0, 0b111);  // 32, 64, 128: held at 32
    ASSERT_EQ(nfd_queue_submit(q, slow, &big, &hold, &running), NFD_SUCCESS);
    ASSERT_EQ(nfd_queue_submit(q, slow, &big, &jo4, &waiting), NFD_SUCCESS);
    ASSERT_EQ(nfd_queue_submit(q, small, &tiny, &jo5, &queued), NFD_SUCCESS);
    while (gate.calls.load() == 0) std::this_thread::yield();
    // The second slow job is first in line and does not fit: it waits, and the small one behind
    // it waits in the queue (no overtaking).
    ASSERT_EQ(poll_until_at_least(waiting, NFD_JOB_WAITING_FOR_MEMORY), NFD_JOB_WAITING_FOR_MEMORY);
    EXPECT_EQ(nfd_job_poll(queued), NFD_JOB_QUEUED);
    EXPECT_EQ(nfd_job_poll(running), NFD_JOB_RUNNING);
    const size_t calls_before = calls.count();
    nfd_job_destroy(queued);
    nfd_job_destroy(waiting);
    gate.open();
    nfd_job_destroy(running);  // the worker ends it at the next level boundary, then frees it
    nfd_job_destroy(done);
    nfd_job_destroy(failed);
    nfd_job_destroy(cancelled);
    nfd_queue_destroy(q);
    EXPECT_EQ(calls.count(), calls_before);  // none after its job was destroyed
    nfd_asset_destroy(slow);
    nfd_asset_destroy(small);
    nfd_context_destroy(ctx);
}

// Destroying the queue cancels what has not run; handles stay valid until destroyed.
TEST(Queue, DestroyQueueWithJobsPending) {
    nfd_context* ctx = make_context(NFD_DEVICE_CPU, 1);
    nfd_asset* slow = make_asset(slow_asset());
    nfd_queue* q = make_queue(ctx, 1);
    const nfd_mesh_options big = mesh_options(kSlowResolution);
    Calls calls(5);
    std::vector<nfd_job*> jobs(5);
    for (int i = 0; i < 5; ++i) {
        const nfd_job_options jo = calls.options(i);
        ASSERT_EQ(nfd_queue_submit(q, slow, &big, &jo, &jobs[size_t(i)]), NFD_SUCCESS);
    }
    nfd_queue_destroy(q);
    EXPECT_EQ(calls.count(), 5u);  // each callback once
    int cancelled = 0;
    for (nfd_job* j : jobs) {
        const nfd_job_status s = nfd_job_poll(j);
        EXPECT_TRUE(s == NFD_JOB_CANCELLED || s == NFD_JOB_DONE) << s;
        cancelled += s == NFD_JOB_CANCELLED;
        EXPECT_EQ(nfd_job_wait(j, kForever), s);
        EXPECT_EQ(nfd_job_cancel(j), NFD_SUCCESS);
    }
    EXPECT_GE(cancelled, 4);  // at most the one the worker had started can have finished
    for (nfd_job* j : jobs) nfd_job_destroy(j);
    nfd_asset_destroy(slow);
    nfd_context_destroy(ctx);
}

// A budget admitting about two jobs' bounds, four workers, twelve jobs: the reservation never
// exceeded the budget, and every job still finished.
TEST(Queue, BudgetHoldsAndAllJobsFinish) {
    nfd_context* ctx = make_context(NFD_DEVICE_CPU, 1);
    const Bytes bytes = read_bytes(golden_path("bunny_sdf_w16", ".nfc"));
    nfd_asset* a = make_asset(bytes);
    const uint64_t bound = first_step_host(bytes, 40);  // the whole job: one level
    const uint64_t budget = 2 * bound + bound / 2;
    nfd_queue* q = make_queue(ctx, 4, budget);
    const nfd_mesh_options mo = mesh_options(40);
    std::vector<nfd_job*> jobs(12);
    for (nfd_job*& j : jobs) ASSERT_EQ(nfd_queue_submit(q, a, &mo, nullptr, &j), NFD_SUCCESS);
    for (nfd_job* j : jobs) EXPECT_EQ(nfd_job_wait(j, kForever), NFD_JOB_DONE);
    nfd_queue_stats st;
    ASSERT_EQ(nfd_queue_get_stats(q, &st), NFD_SUCCESS);
    EXPECT_EQ(st.jobs_done, 12u);
    EXPECT_LE(st.peak_reserved_host_bytes, budget);
    EXPECT_GE(st.peak_reserved_host_bytes, bound);
    EXPECT_EQ(st.reserved_host_bytes, 0u);
    for (nfd_job* j : jobs) nfd_job_destroy(j);
    nfd_queue_destroy(q);
    nfd_asset_destroy(a);
    nfd_context_destroy(ctx);
}

// A job larger than the whole budget fails with NFD_ERROR_LIMIT_EXCEEDED (its callback once,
// FAILED) instead of waiting forever; the jobs behind it run.
TEST(Queue, JobOverTheWholeBudgetFails) {
    nfd_context* ctx = make_context(NFD_DEVICE_CPU);
    const Bytes bytes = blob(1.0f);
    nfd_asset* a = make_asset(bytes);
    const uint64_t budget = job_host_reservation(bytes, 64, 2);
    nfd_queue* q = make_queue(ctx, 1, budget);
    const nfd_mesh_options over = mesh_options(96), fits = mesh_options(64);
    Calls calls(2);
    const nfd_job_options jo0 = calls.options(0), jo1 = calls.options(1);
    nfd_job *big = nullptr, *ok = nullptr;
    ASSERT_EQ(nfd_queue_submit(q, a, &over, &jo0, &big), NFD_SUCCESS);
    ASSERT_EQ(nfd_queue_submit(q, a, &fits, &jo1, &ok), NFD_SUCCESS);
    EXPECT_EQ(nfd_job_wait(big, kForever), NFD_JOB_FAILED);
    nfd_mesh* m = nullptr;
    EXPECT_EQ(nfd_job_take_mesh(big, &m), NFD_ERROR_LIMIT_EXCEEDED);
    EXPECT_EQ(nfd_job_wait(ok, kForever), NFD_JOB_DONE);
    nfd_queue_destroy(q);
    ASSERT_EQ(calls.count(), 2u);
    EXPECT_EQ(calls.statuses[0], NFD_JOB_FAILED);
    EXPECT_EQ(calls.statuses[1], NFD_JOB_DONE);
    nfd_job_destroy(big);
    nfd_job_destroy(ok);
    nfd_asset_destroy(a);
    nfd_context_destroy(ctx);
}

// Fire and forget: the callback takes the mesh and destroys its own job.
struct Forget {
    std::atomic<int> done{0};
    std::atomic<size_t> triangles{0};
    static void take_and_destroy(nfd_job* job, nfd_job_status status, void* user) {
        auto* f = static_cast<Forget*>(user);
        nfd_mesh* m = nullptr;
        if (status == NFD_JOB_DONE && nfd_job_take_mesh(job, &m) == NFD_SUCCESS) {
            nfd_mesh_data d;
            nfd_mesh_get_data(m, &d);
            f->triangles += d.triangle_count;
        }
        nfd_mesh_destroy(m);
        nfd_job_destroy(job);
        ++f->done;
    }
};

TEST(Queue, CallbackMayDestroyItsOwnJob) {
    nfd_context* ctx = make_context(NFD_DEVICE_CPU);
    nfd_asset* a = make_asset(blob(1.0f));
    nfd_queue* q = make_queue(ctx, 2);
    const nfd_mesh_options mo = mesh_options(24);
    Forget forget;
    nfd_job_options jo = {};
    jo.callback = Forget::take_and_destroy;
    jo.user_data = &forget;
    for (int i = 0; i < 4; ++i) {
        nfd_job* j = nullptr;
        ASSERT_EQ(nfd_queue_submit(q, a, &mo, &jo, &j), NFD_SUCCESS);  // the callback owns it
    }
    while (forget.done.load() < 4) std::this_thread::yield();
    nfd_queue_destroy(q);
    EXPECT_EQ(forget.done.load(), 4);
    EXPECT_GT(forget.triangles.load(), 0u);
    nfd_asset_destroy(a);
    nfd_context_destroy(ctx);
}

#ifdef SCHED_BATCH
// Workers run under SCHED_BATCH (parallel.h, run_as_background_thread): a started job's callback
// runs on its worker.
TEST(Queue, WorkersRunAsBackgroundThreads) {
    nfd_context* ctx = make_context(NFD_DEVICE_CPU);
    nfd_asset* a = make_asset(blob(1.0f));
    nfd_queue* q = make_queue(ctx, 1);
    const nfd_mesh_options mo = mesh_options(24);
    std::atomic<int> policy{-1};
    nfd_job_options jo = {};
    jo.callback = [](nfd_job*, nfd_job_status, void* user) {
        static_cast<std::atomic<int>*>(user)->store(sched_getscheduler(0));
    };
    jo.user_data = &policy;
    nfd_job* job = nullptr;
    ASSERT_EQ(nfd_queue_submit(q, a, &mo, &jo, &job), NFD_SUCCESS);
    EXPECT_EQ(nfd_job_wait(job, UINT64_MAX), NFD_JOB_DONE);
    nfd_queue_destroy(q);  // the callback has run once the workers are joined
    EXPECT_EQ(policy.load(), SCHED_BATCH);
    nfd_job_destroy(job);
    nfd_asset_destroy(a);
    nfd_context_destroy(ctx);
}
#endif

// A wait that times out returns the status then, not final; 0 is a poll.
TEST_F(QueueOnBlob, WaitWithTimeout) {
    const nfd_mesh_options mo = mesh_options(16);
    Gate gate;
    const nfd_job_options hold = gate.job_options(1);
    nfd_job *first = nullptr, *job = nullptr;
    ASSERT_EQ(nfd_queue_submit(q, a, &mo, &hold, &first), NFD_SUCCESS);
    ASSERT_EQ(nfd_queue_submit(q, a, &mo, nullptr, &job), NFD_SUCCESS);
    EXPECT_EQ(nfd_job_wait(job, 0), NFD_JOB_QUEUED);
    EXPECT_EQ(nfd_job_wait(job, 2000000), NFD_JOB_QUEUED);  // 2 ms: the worker is held
    gate.open();
    EXPECT_EQ(nfd_job_wait(job, kForever), NFD_JOB_DONE);
    EXPECT_EQ(nfd_job_wait(job, 0), NFD_JOB_DONE);
    nfd_job_destroy(job);
    nfd_job_destroy(first);
}

TEST(Queue, NullAndInvalidArguments) {
    nfd_context* ctx = make_context(NFD_DEVICE_CPU);
    nfd_asset* a = make_asset(blob(1.0f));
    nfd_queue* q = reinterpret_cast<nfd_queue*>(0x1);
    EXPECT_EQ(nfd_queue_create(ctx, nullptr, nullptr), NFD_ERROR_INVALID_ARGUMENT);
    EXPECT_EQ(nfd_queue_create(nullptr, nullptr, &q), NFD_ERROR_INVALID_ARGUMENT);
    EXPECT_EQ(q, nullptr);
    nfd_queue_options qo = {};
    qo.struct_size = 3;  // smaller than the first layout
    EXPECT_EQ(nfd_queue_create(ctx, &qo, &q), NFD_ERROR_INVALID_ARGUMENT);
    ASSERT_EQ(nfd_queue_create(ctx, nullptr, &q), NFD_SUCCESS);  // defaults

    nfd_job* j = reinterpret_cast<nfd_job*>(0x1);
    EXPECT_EQ(nfd_queue_submit(q, a, nullptr, nullptr, nullptr), NFD_ERROR_INVALID_ARGUMENT);
    EXPECT_EQ(nfd_queue_submit(nullptr, a, nullptr, nullptr, &j), NFD_ERROR_INVALID_ARGUMENT);
    EXPECT_EQ(j, nullptr);
    EXPECT_EQ(nfd_queue_submit(q, nullptr, nullptr, nullptr, &j), NFD_ERROR_INVALID_ARGUMENT);
    nfd_mesh_options mo = mesh_options(NFD_MAX_RESOLUTION + 1);
    EXPECT_EQ(nfd_queue_submit(q, a, &mo, nullptr, &j), NFD_ERROR_LIMIT_EXCEEDED);
    mo = mesh_options(NFD_MIN_RESOLUTION - 1);
    EXPECT_EQ(nfd_queue_submit(q, a, &mo, nullptr, &j), NFD_ERROR_LIMIT_EXCEEDED);
    struct {
        nfd_job_options known;
        uint32_t unknown;
    } newer = {};
    newer.known.struct_size = sizeof newer;
    newer.unknown = 1;  // a field this library does not know, not zero
    EXPECT_EQ(nfd_queue_submit(q, a, nullptr, &newer.known, &j), NFD_ERROR_INVALID_ARGUMENT);
    EXPECT_EQ(j, nullptr);

    nfd_queue_stats st;
    EXPECT_EQ(nfd_queue_get_stats(nullptr, &st), NFD_ERROR_INVALID_ARGUMENT);
    EXPECT_EQ(nfd_queue_get_stats(q, nullptr), NFD_ERROR_INVALID_ARGUMENT);
    EXPECT_EQ(nfd_job_poll(nullptr), NFD_JOB_FAILED);
    EXPECT_EQ(nfd_job_wait(nullptr, 0), NFD_JOB_FAILED);
    EXPECT_EQ(nfd_job_cancel(nullptr), NFD_ERROR_INVALID_ARGUMENT);
    nfd_mesh* m = reinterpret_cast<nfd_mesh*>(0x1);
    EXPECT_EQ(nfd_job_take_mesh(nullptr, &m), NFD_ERROR_INVALID_ARGUMENT);
    EXPECT_EQ(m, nullptr);
    ASSERT_EQ(nfd_queue_submit(q, a, nullptr, nullptr, &j), NFD_SUCCESS);  // defaults: 256
    EXPECT_EQ(nfd_job_take_mesh(j, nullptr), NFD_ERROR_INVALID_ARGUMENT);
    nfd_job_destroy(j);
    nfd_job_destroy(nullptr);
    nfd_queue_destroy(nullptr);
    nfd_queue_destroy(q);
    nfd_asset_destroy(a);
    nfd_context_destroy(ctx);
}

// Takes every mesh a job delivers, in its callback (a newer level would replace an untaken one),
// with the level it is, the status of each call, and how far the job was.
struct Levels {
    std::mutex mutex;
    std::vector<nfd_job_status> statuses;
    std::vector<nfd_mesh*> meshes;
    std::vector<uint32_t> resolutions;
    static void take(nfd_job* job, nfd_job_status status, void* user) {
        auto* self = static_cast<Levels*>(user);
        nfd_mesh* m = nullptr;
        const nfd_result r = nfd_job_take_mesh(job, &m);
        nfd_job_progress p = {};
        p.struct_size = sizeof p;
        EXPECT_EQ(nfd_job_get_progress(job, &p), NFD_SUCCESS);
        std::lock_guard<std::mutex> lock(self->mutex);
        self->statuses.push_back(status);
        if (r == NFD_SUCCESS && m) {
            self->meshes.push_back(m);
            self->resolutions.push_back(p.taken_mesh_resolution);
        }
    }
    nfd_job_options options(uint32_t mesh_levels) {
        nfd_job_options o = {};
        o.struct_size = sizeof o;
        o.callback = take;
        o.user_data = this;
        o.mesh_levels = mesh_levels;
        return o;
    }
    ~Levels() {
        for (nfd_mesh* m : meshes) nfd_mesh_destroy(m);
    }
};

// Every level of the ladder of 128 (32, 64, 128) on the golden vectors, SDF and UDF: delivered
// in order, one RUNNING callback per coarser level and DONE with the final one, each mesh
// byte-identical to nfd_mesh_extract's at its resolution on the same context.
void levels_match_mesh_extract(nfd_context* ctx, uint32_t workers) {
    const std::vector<std::string> names = golden_names();
    std::vector<Levels> levels(names.size());
    std::vector<nfd_asset*> assets;
    nfd_queue* q = make_queue(ctx, workers);
    std::vector<nfd_job*> jobs(names.size());
    const nfd_mesh_options mo = mesh_options(128);
    for (size_t i = 0; i < names.size(); ++i) {
        assets.push_back(make_asset(read_bytes(golden_path(names[i], ".nfc"))));
        const nfd_job_options jo = levels[i].options(0b111);
        ASSERT_EQ(nfd_queue_submit(q, assets[i], &mo, &jo, &jobs[i]), NFD_SUCCESS);
    }
    for (size_t i = 0; i < names.size(); ++i) {
        SCOPED_TRACE(names[i]);
        ASSERT_EQ(nfd_job_wait(jobs[i], kForever), NFD_JOB_DONE);
        nfd_job_progress p = {};
        ASSERT_EQ(nfd_job_get_progress(jobs[i], &p), NFD_SUCCESS);  // 0: the first layout
        EXPECT_EQ(p.levels_done, 3u);
        EXPECT_EQ(p.levels_total, 3u);
        EXPECT_EQ(p.newest_mesh_resolution, 128u);
        EXPECT_EQ(p.taken_mesh_resolution, 128u);
        EXPECT_EQ(p.final_resolution, 128u);
        nfd_job_destroy(jobs[i]);
    }
    nfd_queue_destroy(q);  // the context is the queue's while it exists
    for (size_t i = 0; i < names.size(); ++i) {
        SCOPED_TRACE(names[i]);
        EXPECT_EQ(levels[i].statuses,
                  (std::vector<nfd_job_status>{NFD_JOB_RUNNING, NFD_JOB_RUNNING, NFD_JOB_DONE}));
        ASSERT_EQ(levels[i].resolutions, (std::vector<uint32_t>{32, 64, 128}));
        for (size_t l = 0; l < 3; ++l) {
            const nfd_mesh_options at = mesh_options(levels[i].resolutions[l]);
            nfd_mesh* expected = nullptr;
            ASSERT_EQ(nfd_mesh_extract(ctx, assets[i], &at, &expected), NFD_SUCCESS);
            EXPECT_TRUE(same_mesh(levels[i].meshes[l], expected)) << "level " << l;
            nfd_mesh_destroy(expected);
        }
    }
    for (nfd_asset* a : assets) nfd_asset_destroy(a);
}

TEST(Queue, LevelsInOrderMatchMeshExtractCpu) {
    nfd_context* ctx = make_context(NFD_DEVICE_CPU, 1);
    levels_match_mesh_extract(ctx, 2);
    nfd_context_destroy(ctx);
}

TEST_F(QueueVulkan, LevelsInOrderMatchMeshExtractVulkan) {
    levels_match_mesh_extract(ctx, 1);
}

// Cancelled while its first level's callback runs: the job ends CANCELLED at that level's
// boundary, evaluates no further level, and frees the mesh the callback did not take.
TEST(Queue, CancelBetweenLevels) {
    nfd_context* ctx = make_context(NFD_DEVICE_CPU, 1);
    nfd_asset* a = make_asset(slow_asset());
    nfd_queue* q = make_queue(ctx, 1);
    const nfd_mesh_options mo = mesh_options(kSlowResolution);
    Gate gate;
    const nfd_job_options jo = gate.job_options(0, 0b111);
    nfd_job* job = nullptr;
    ASSERT_EQ(nfd_queue_submit(q, a, &mo, &jo, &job), NFD_SUCCESS);
    while (gate.calls.load() == 0) std::this_thread::yield();
    nfd_job_progress p = {};
    ASSERT_EQ(nfd_job_get_progress(job, &p), NFD_SUCCESS);
    EXPECT_EQ(p.levels_done, 1u);
    EXPECT_EQ(p.newest_mesh_resolution, 32u);
    EXPECT_EQ(nfd_job_cancel(job), NFD_SUCCESS);
    gate.open();
    EXPECT_EQ(nfd_job_wait(job, kForever), NFD_JOB_CANCELLED);
    ASSERT_EQ(nfd_job_get_progress(job, &p), NFD_SUCCESS);
    EXPECT_EQ(p.levels_done, 1u);  // 64 was never evaluated
    nfd_mesh* m = nullptr;
    EXPECT_EQ(nfd_job_take_mesh(job, &m), NFD_ERROR_CANCELLED);
    EXPECT_EQ(m, nullptr);
    EXPECT_EQ(gate.calls.load(), 2);  // RUNNING at 32, then CANCELLED
    nfd_job_destroy(job);
    nfd_queue_destroy(q);
    nfd_asset_destroy(a);
    nfd_context_destroy(ctx);
}

// A budget that admits one job's largest reservation but not two, two workers, three jobs of
// every level: two jobs start (their first steps fit together), then both grow. None waits
// forever: all finish DONE, the reservation never exceeded the budget, each job delivered its
// levels once each, in order (a job that restarted to let the other finish delivers none
// twice), and the final meshes are nfd_mesh_extract's.
TEST(Queue, BudgetForOneJobAtItsLargestAndTwoWorkers) {
    nfd_context* ctx = make_context(NFD_DEVICE_CPU, 1);
    const Bytes bytes = read_bytes(golden_path("bunny_sdf_w16", ".nfc"));
    nfd_asset* a = make_asset(bytes);
    const uint32_t r = 128;
    const uint64_t largest = job_host_reservation(bytes, r, 1);
    ASSERT_GE(largest, 2 * first_step_host(bytes, r));  // two jobs can start together
    const uint64_t budget = largest + largest / 2;
    const nfd_mesh_options mo = mesh_options(r);
    nfd_mesh* expected = nullptr;
    ASSERT_EQ(nfd_mesh_extract(ctx, a, &mo, &expected), NFD_SUCCESS);
    nfd_queue* q = make_queue(ctx, 2, budget);
    std::vector<Levels> levels(3);
    std::vector<nfd_job*> jobs(3);
    for (size_t i = 0; i < jobs.size(); ++i) {
        const nfd_job_options jo = levels[i].options(0b111);
        ASSERT_EQ(nfd_queue_submit(q, a, &mo, &jo, &jobs[i]), NFD_SUCCESS);
    }
    for (size_t i = 0; i < jobs.size(); ++i) {
        SCOPED_TRACE(i);
        ASSERT_EQ(nfd_job_wait(jobs[i], kForever), NFD_JOB_DONE);
        EXPECT_EQ(levels[i].resolutions, (std::vector<uint32_t>{32, 64, 128}));
        ASSERT_EQ(levels[i].meshes.size(), 3u);
        EXPECT_TRUE(same_mesh(levels[i].meshes.back(), expected));
    }
    nfd_queue_stats st;
    ASSERT_EQ(nfd_queue_get_stats(q, &st), NFD_SUCCESS);
    EXPECT_EQ(st.jobs_done, 3u);
    EXPECT_LE(st.peak_reserved_host_bytes, budget);
    EXPECT_GE(st.peak_reserved_host_bytes, largest);
    EXPECT_EQ(st.reserved_host_bytes, 0u);
    nfd_mesh_destroy(expected);
    for (nfd_job* j : jobs) nfd_job_destroy(j);
    nfd_queue_destroy(q);
    nfd_asset_destroy(a);
    nfd_context_destroy(ctx);
}

// A running job that waits for memory to grow ends at once when cancelled: job A holds its first
// step's reservation inside its first level's callback, job B's second level does not fit beside
// it; B is cancelled while A is still held.
TEST(Queue, CancelWhileWaitingToGrow) {
    nfd_context* ctx = make_context(NFD_DEVICE_CPU, 1);
    const Bytes bytes = slow_asset();
    nfd_asset* a = make_asset(bytes);
    nfd_queue* q = make_queue(ctx, 2, 2 * first_step_host(bytes, kSlowResolution));
    const nfd_mesh_options mo = mesh_options(kSlowResolution);
    Gate gate;
    const nfd_job_options hold = gate.job_options(0, 0b111);
    nfd_job *held = nullptr, *grows = nullptr;
    ASSERT_EQ(nfd_queue_submit(q, a, &mo, &hold, &held), NFD_SUCCESS);
    while (gate.calls.load() == 0) std::this_thread::yield();
    ASSERT_EQ(nfd_queue_submit(q, a, &mo, nullptr, &grows), NFD_SUCCESS);
    nfd_job_progress p = {};
    while (nfd_job_get_progress(grows, &p) == NFD_SUCCESS && p.levels_done == 0)
        std::this_thread::yield();
    EXPECT_EQ(p.levels_done, 1u);
    EXPECT_EQ(nfd_job_poll(grows), NFD_JOB_RUNNING);
    EXPECT_EQ(nfd_job_cancel(grows), NFD_SUCCESS);
    EXPECT_EQ(nfd_job_wait(grows, kForever), NFD_JOB_CANCELLED);
    EXPECT_EQ(gate.calls.load(), 1);  // A is still held
    gate.open();
    EXPECT_TRUE(is_final(nfd_job_wait(held, kForever)));
    nfd_job_destroy(grows);
    nfd_job_destroy(held);
    nfd_queue_destroy(q);
    nfd_asset_destroy(a);
    nfd_context_destroy(ctx);
}

// mesh_levels as nfd_extraction_options', except 0: the final level must be in it, no bit past
// the ladder.
TEST_F(QueueOnBlob, MeshLevelsOutsideTheLadderAreRejected) {
    const nfd_mesh_options mo = mesh_options(128);
    nfd_job_options jo = {};
    jo.struct_size = sizeof jo;
    nfd_job* j = reinterpret_cast<nfd_job*>(0x1);
    for (uint32_t bad : {0b011u, 0b1111u, 0b001u}) {
        jo.mesh_levels = bad;
        EXPECT_EQ(nfd_queue_submit(q, a, &mo, &jo, &j), NFD_ERROR_INVALID_ARGUMENT) << bad;
        EXPECT_EQ(j, nullptr);
    }
    nfd_job_progress p = {};
    EXPECT_EQ(nfd_job_get_progress(nullptr, &p), NFD_ERROR_INVALID_ARGUMENT);
}

}  // namespace
}  // namespace nfd::test
