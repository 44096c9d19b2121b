// Stream jobs (nfd_queue_submit_stream, nfd_job_feed, nfd_job_finish_input): submitted before
// the first byte, fed in any split, started as soon as the asset they need is there, and then
// byte-identical to nfd_queue_submit on that asset; truncated, corrupt and cancelled input ends
// them with the stream's codes. Run under ThreadSanitizer and AddressSanitizer by
// scripts/sanitize.sh (the Queue* filter).
#include <gtest/gtest.h>
#include <nfdecode/nfdecode.h>

#include <cmath>
#include <cstring>
#include <random>
#include <string>
#include <vector>

#include "queue_util.h"
#include "test_util.h"

namespace nfd::test {
namespace {

constexpr uint32_t kResolution = 32;

// A CPU context and a one-worker queue.
struct QueueStream : ::testing::Test {
    nfd_context* ctx = make_context(NFD_DEVICE_CPU);
    nfd_queue* q = make_queue(ctx, 1);
    void TearDown() override {
        nfd_queue_destroy(q);
        nfd_context_destroy(ctx);
    }

    // A job on a new, empty stream.
    nfd_job* submit(const nfd_mesh_options& mo, const nfd_job_options* jo = nullptr) {
        nfd_stream* s = nullptr;
        EXPECT_EQ(nfd_stream_create(nullptr, &s), NFD_SUCCESS);
        nfd_job* job = nullptr;
        EXPECT_EQ(nfd_queue_submit_stream(q, s, &mo, jo, &job), NFD_SUCCESS);
        if (!job) nfd_stream_destroy(s);
        return job;
    }

    // nfd_mesh_extract's mesh of `bytes` on this context.
    nfd_mesh* expected(const Bytes& bytes, const nfd_mesh_options& mo) {
        nfd_asset* a = make_asset(bytes);
        nfd_mesh* m = nullptr;
        EXPECT_EQ(nfd_mesh_extract(ctx, a, &mo, &m), NFD_SUCCESS);
        nfd_asset_destroy(a);
        return m;
    }
};

// Where the bytes after GEOM begin, and with them the 8 that show the next chunk is not `fram`.
size_t geometry_end(const Bytes& file) {
    const size_t length = size_t(file[20]) | size_t(file[21]) << 8 | size_t(file[22]) << 16 |
                          size_t(file[23]) << 24;
    return 16 + 8 + length + 4;
}

::testing::AssertionResult takes_mesh_like(nfd_job* job, const nfd_mesh* expected) {
    if (nfd_job_wait(job, UINT64_MAX) != NFD_JOB_DONE)
        return ::testing::AssertionFailure() << "status " << nfd_job_poll(job);
    nfd_mesh* m = nullptr;
    if (nfd_job_take_mesh(job, &m) != NFD_SUCCESS || !m) return ::testing::AssertionFailure() << "no mesh";
    ::testing::AssertionResult same = same_mesh(m, expected);
    double offset[3], want[3];
    if (same && (nfd_mesh_get_offset(m, offset) != NFD_SUCCESS ||
                 nfd_mesh_get_offset(expected, want) != NFD_SUCCESS ||
                 std::memcmp(offset, want, sizeof offset)))
        same = ::testing::AssertionFailure() << "offsets differ";
    nfd_mesh_destroy(m);
    return same;
}

// Every golden file, fed in random pieces (one byte at a time for the first): the job waits for
// input until the file is there, then gives nfd_mesh_extract's mesh, colours and offset included.
TEST_F(QueueStream, RandomSplitsMatchMeshExtract) {
    const nfd_mesh_options mo = mesh_options(kResolution);
    std::mt19937 rng(7);
    bool first = true;
    for (const std::string& name : golden_names()) {
        SCOPED_TRACE(name);
        const Bytes bytes = read_bytes(golden_path(name, ".nfc"));
        nfd_job* job = submit(mo);
        ASSERT_NE(job, nullptr);
        EXPECT_EQ(nfd_job_poll(job), NFD_JOB_WAITING_FOR_INPUT);
        size_t at = 0;
        while (at < bytes.size()) {
            const size_t n = first ? 1 : std::min(bytes.size() - at, size_t(rng() % 700));
            if (at + n < bytes.size()) {
                EXPECT_EQ(nfd_job_poll(job), NFD_JOB_WAITING_FOR_INPUT);  // the file is not complete
            }
            nfd_stream_progress p;
            ASSERT_EQ(nfd_job_feed(job, bytes.data() + at, n, &p), NFD_SUCCESS);
            at += n;
            EXPECT_EQ(p.bytes_consumed, at);
        }
        first = false;
        EXPECT_EQ(nfd_job_finish_input(job), NFD_SUCCESS);
        nfd_mesh* want = expected(bytes, mo);
        EXPECT_TRUE(takes_mesh_like(job, want));
        nfd_mesh_destroy(want);
        nfd_job_destroy(job);
    }
}

// With skip_colour the job starts once the geometry is placed (8 bytes into the chunk after
// GEOM) and finishes before the colour arrives; without, it waits for the whole file and its
// mesh carries the colours.
TEST_F(QueueStream, GeometryJobsStartBeforeTheColour) {
    const Bytes bytes = read_bytes(golden_path("milk_udf_w16_c16", ".nfc"));
    const size_t ready = geometry_end(bytes) + 8;
    ASSERT_LT(ready, bytes.size());
    nfd_mesh_options geometry_only = mesh_options(kResolution);
    geometry_only.skip_colour = 1;
    const nfd_mesh_options coloured = mesh_options(kResolution);
    nfd_job* early = submit(geometry_only);
    nfd_job* full = submit(coloured);
    ASSERT_TRUE(early && full);
    for (nfd_job* job : {early, full}) {
        ASSERT_EQ(nfd_job_feed(job, bytes.data(), ready - 1, nullptr), NFD_SUCCESS);
        EXPECT_EQ(nfd_job_poll(job), NFD_JOB_WAITING_FOR_INPUT);
        ASSERT_EQ(nfd_job_feed(job, bytes.data() + ready - 1, 1, nullptr), NFD_SUCCESS);
    }
    nfd_mesh* plain = expected(bytes, geometry_only);
    EXPECT_TRUE(takes_mesh_like(early, plain));  // done with the colour chunk still to come
    EXPECT_EQ(nfd_job_poll(full), NFD_JOB_WAITING_FOR_INPUT);
    for (nfd_job* job : {early, full}) {
        EXPECT_EQ(nfd_job_feed(job, bytes.data() + ready, bytes.size() - ready, nullptr), NFD_SUCCESS);
        EXPECT_EQ(nfd_job_finish_input(job), NFD_SUCCESS);
    }
    nfd_mesh* with_colour = expected(bytes, coloured);
    EXPECT_TRUE(takes_mesh_like(full, with_colour));
    const float* colours = nullptr;
    EXPECT_EQ(nfd_mesh_get_colours(with_colour, &colours), NFD_SUCCESS);
    EXPECT_NE(colours, nullptr);  // so takes_mesh_like compared colours too
    nfd_mesh_destroy(plain);
    nfd_mesh_destroy(with_colour);
    nfd_job_destroy(early);
    nfd_job_destroy(full);
}

// A file that ends early, or whose GEOM is damaged, fails a job still waiting for it with the
// stream's code; the callback runs on the thread that fed it; later calls repeat the code.
TEST_F(QueueStream, TruncatedOrCorruptInputFailsTheJob) {
    const Bytes bytes = read_bytes(golden_path("bunny_sdf_w16", ".nfc"));
    const nfd_mesh_options mo = mesh_options(kResolution);
    {
        Calls calls(1);
        const nfd_job_options jo = calls.options(0);
        nfd_job* job = submit(mo, &jo);
        ASSERT_EQ(nfd_job_feed(job, bytes.data(), bytes.size() / 2, nullptr), NFD_SUCCESS);
        EXPECT_EQ(nfd_job_finish_input(job), NFD_ERROR_TRUNCATED);
        EXPECT_EQ(nfd_job_poll(job), NFD_JOB_FAILED);
        ASSERT_EQ(calls.count(), 1u);
        EXPECT_EQ(calls.statuses[0], NFD_JOB_FAILED);
        EXPECT_EQ(calls.threads[0], std::this_thread::get_id());
        nfd_mesh* m = nullptr;
        EXPECT_EQ(nfd_job_take_mesh(job, &m), NFD_ERROR_TRUNCATED);
        EXPECT_EQ(nfd_job_feed(job, bytes.data(), 1, nullptr), NFD_ERROR_TRUNCATED);
        EXPECT_EQ(nfd_job_finish_input(job), NFD_ERROR_TRUNCATED);
        EXPECT_EQ(calls.count(), 1u);
        nfd_job_destroy(job);
    }
    {
        Bytes damaged = bytes;
        damaged[40] ^= 0x10;  // inside GEOM's payload: its CRC fails
        nfd_job* job = submit(mo);
        EXPECT_EQ(nfd_job_feed(job, damaged.data(), damaged.size(), nullptr), NFD_ERROR_CORRUPT);
        EXPECT_EQ(nfd_job_wait(job, UINT64_MAX), NFD_JOB_FAILED);
        nfd_mesh* m = nullptr;
        EXPECT_EQ(nfd_job_take_mesh(job, &m), NFD_ERROR_CORRUPT);
        nfd_job_destroy(job);
    }
    nfd_queue_stats st;
    ASSERT_EQ(nfd_queue_get_stats(q, &st), NFD_SUCCESS);
    EXPECT_EQ(st.jobs_failed, 2u);
}

// Hostile values that pass the CRC: a file the parser refuses fails the job with the one-shot
// parser's code; files it accepts (damaged steps, levels, frame) end DONE with a finite mesh or
// with an error code, as nfd_queue_submit would.
TEST_F(QueueStream, HostileValuesBehindValidCrcs) {
    const nfd_mesh_options mo = mesh_options(16);
    GeomSpec spec = closed_blob();
    spec.num_frequencies = 30;  // over MAX_FREQUENCIES; the file's CRCs are right
    const Bytes refused = geom_file(spec);
    nfd_asset* a = nullptr;
    const nfd_result one_shot = nfd_asset_create(refused.data(), refused.size(), &a);
    ASSERT_NE(one_shot, NFD_SUCCESS);
    nfd_job* job = submit(mo);
    EXPECT_EQ(nfd_job_feed(job, refused.data(), refused.size(), nullptr), one_shot);
    EXPECT_EQ(nfd_job_wait(job, UINT64_MAX), NFD_JOB_FAILED);
    nfd_mesh* m = nullptr;
    EXPECT_EQ(nfd_job_take_mesh(job, &m), one_shot);
    nfd_job_destroy(job);

    size_t accepted = 0;
    for_each_accepted_damaged_file(geom_payload(closed_blob()), 7, {0x01, 0x80},
                                   [&](size_t i, const Bytes& bytes, const Geometry&) {
        SCOPED_TRACE(i);
        ++accepted;
        nfd_job* j = submit(mo);
        EXPECT_EQ(nfd_job_feed(j, bytes.data(), bytes.size(), nullptr), NFD_SUCCESS);
        EXPECT_EQ(nfd_job_finish_input(j), NFD_SUCCESS);
        const nfd_job_status st = nfd_job_wait(j, UINT64_MAX);
        nfd_mesh* mesh = nullptr;
        const nfd_result r = nfd_job_take_mesh(j, &mesh);
        if (st == NFD_JOB_DONE) {
            ASSERT_EQ(r, NFD_SUCCESS);
            nfd_mesh_data d{};
            ASSERT_EQ(nfd_mesh_get_data(mesh, &d), NFD_SUCCESS);
            for (size_t k = 0; k < 3 * d.vertex_count; ++k) ASSERT_TRUE(std::isfinite(d.positions[k]));
        } else {
            EXPECT_EQ(st, NFD_JOB_FAILED);
            EXPECT_NE(r, NFD_SUCCESS);
        }
        nfd_mesh_destroy(mesh);
        nfd_job_destroy(j);
    });
    EXPECT_GT(accepted, 10u);
}

// Damage after the geometry a started job needed: the feed reports it, the job still finishes.
TEST_F(QueueStream, DamageAfterTheStartIsTheCallersToHandle) {
    Bytes bytes = read_bytes(golden_path("milk_udf_w16_c16", ".nfc"));
    const size_t ready = geometry_end(bytes) + 8;
    bytes[ready + 4] ^= 0x01;  // inside the colour chunk's payload
    nfd_mesh_options mo = mesh_options(kResolution);
    mo.skip_colour = 1;
    nfd_job* job = submit(mo);
    ASSERT_EQ(nfd_job_feed(job, bytes.data(), ready, nullptr), NFD_SUCCESS);
    EXPECT_EQ(nfd_job_feed(job, bytes.data() + ready, bytes.size() - ready, nullptr),
              NFD_ERROR_CORRUPT);
    EXPECT_EQ(nfd_job_finish_input(job), NFD_ERROR_CORRUPT);
    EXPECT_EQ(nfd_job_wait(job, UINT64_MAX), NFD_JOB_DONE);
    nfd_job_destroy(job);
}

// Cancelled while waiting for input: CANCELLED at once (callback on this thread), feeds refused;
// destroyed while waiting, or left to the queue's destruction: the stream goes with the job.
TEST_F(QueueStream, CancelDestroyAndQueueDestroyWhileWaiting) {
    const Bytes bytes = read_bytes(golden_path("bunny_sdf_w16", ".nfc"));
    const nfd_mesh_options mo = mesh_options(kResolution);
    Calls calls(2);
    const nfd_job_options jo = calls.options(0);
    nfd_job* job = submit(mo, &jo);
    ASSERT_EQ(nfd_job_feed(job, bytes.data(), 100, nullptr), NFD_SUCCESS);
    EXPECT_EQ(nfd_job_cancel(job), NFD_SUCCESS);
    EXPECT_EQ(nfd_job_poll(job), NFD_JOB_CANCELLED);
    ASSERT_EQ(calls.count(), 1u);
    EXPECT_EQ(calls.threads[0], std::this_thread::get_id());
    EXPECT_EQ(nfd_job_feed(job, bytes.data() + 100, 10, nullptr), NFD_ERROR_CANCELLED);
    EXPECT_EQ(nfd_job_finish_input(job), NFD_ERROR_CANCELLED);
    nfd_job_destroy(job);

    nfd_job* dropped = submit(mo);
    ASSERT_EQ(nfd_job_feed(dropped, bytes.data(), 200, nullptr), NFD_SUCCESS);
    nfd_job_destroy(dropped);  // ASan: the stream and its buffered chunk are freed

    const nfd_job_options jo1 = calls.options(1);
    nfd_job* left = submit(mo, &jo1);
    nfd_queue_destroy(q);
    q = nullptr;
    EXPECT_EQ(nfd_job_poll(left), NFD_JOB_CANCELLED);
    EXPECT_EQ(calls.count(), 2u);
    EXPECT_EQ(nfd_job_feed(left, bytes.data(), 10, nullptr), NFD_ERROR_CANCELLED);
    nfd_job_destroy(left);
}

// A stream fed before it is submitted: complete, the job is queued at once; failed, submit
// refuses it with the stream's code and the caller keeps it; its complete asset taken, refused.
TEST_F(QueueStream, StreamsFedBeforeTheSubmit) {
    const Bytes bytes = read_bytes(golden_path("bunny_sdf_w16", ".nfc"));
    const nfd_mesh_options mo = mesh_options(kResolution);
    nfd_stream* s = nullptr;
    ASSERT_EQ(nfd_stream_create(nullptr, &s), NFD_SUCCESS);
    ASSERT_EQ(nfd_stream_feed(s, bytes.data(), bytes.size(), nullptr), NFD_SUCCESS);
    nfd_job* job = nullptr;
    ASSERT_EQ(nfd_queue_submit_stream(q, s, &mo, nullptr, &job), NFD_SUCCESS);
    EXPECT_NE(nfd_job_poll(job), NFD_JOB_WAITING_FOR_INPUT);
    nfd_mesh* want = expected(bytes, mo);
    EXPECT_TRUE(takes_mesh_like(job, want));
    EXPECT_EQ(nfd_job_finish_input(job), NFD_SUCCESS);
    nfd_mesh_destroy(want);
    nfd_job_destroy(job);

    Bytes damaged = bytes;
    damaged[40] ^= 0x10;
    ASSERT_EQ(nfd_stream_create(nullptr, &s), NFD_SUCCESS);
    EXPECT_EQ(nfd_stream_feed(s, damaged.data(), damaged.size(), nullptr), NFD_ERROR_CORRUPT);
    job = reinterpret_cast<nfd_job*>(0x1);
    EXPECT_EQ(nfd_queue_submit_stream(q, s, &mo, nullptr, &job), NFD_ERROR_CORRUPT);
    EXPECT_EQ(job, nullptr);
    nfd_stream_destroy(s);  // still the caller's

    ASSERT_EQ(nfd_stream_create(nullptr, &s), NFD_SUCCESS);
    ASSERT_EQ(nfd_stream_feed(s, bytes.data(), bytes.size(), nullptr), NFD_SUCCESS);
    nfd_asset* a = nullptr;
    ASSERT_EQ(nfd_stream_take_complete_asset(s, &a), NFD_SUCCESS);
    EXPECT_EQ(nfd_queue_submit_stream(q, s, &mo, nullptr, &job), NFD_ERROR_INVALID_ARGUMENT);
    nfd_asset_destroy(a);
    nfd_stream_destroy(s);
}

TEST_F(QueueStream, NullAndInvalidArguments) {
    const nfd_mesh_options mo = mesh_options(kResolution);
    nfd_stream* s = nullptr;
    ASSERT_EQ(nfd_stream_create(nullptr, &s), NFD_SUCCESS);
    nfd_job* job = reinterpret_cast<nfd_job*>(0x1);
    EXPECT_EQ(nfd_queue_submit_stream(nullptr, s, &mo, nullptr, &job), NFD_ERROR_INVALID_ARGUMENT);
    EXPECT_EQ(job, nullptr);
    EXPECT_EQ(nfd_queue_submit_stream(q, nullptr, &mo, nullptr, &job), NFD_ERROR_INVALID_ARGUMENT);
    EXPECT_EQ(nfd_queue_submit_stream(q, s, &mo, nullptr, nullptr), NFD_ERROR_INVALID_ARGUMENT);
    nfd_mesh_options huge = mesh_options(1u << 20);
    EXPECT_EQ(nfd_queue_submit_stream(q, s, &huge, nullptr, &job), NFD_ERROR_LIMIT_EXCEEDED);
    nfd_stream_destroy(s);  // every refusal left it to the caller

    EXPECT_EQ(nfd_job_feed(nullptr, "x", 1, nullptr), NFD_ERROR_INVALID_ARGUMENT);
    EXPECT_EQ(nfd_job_finish_input(nullptr), NFD_ERROR_INVALID_ARGUMENT);
    nfd_asset* a = make_asset(blob(1.0f));
    ASSERT_EQ(nfd_queue_submit(q, a, &mo, nullptr, &job), NFD_SUCCESS);
    EXPECT_EQ(nfd_job_feed(job, "x", 1, nullptr), NFD_ERROR_INVALID_ARGUMENT);  // not a stream job
    EXPECT_EQ(nfd_job_finish_input(job), NFD_ERROR_INVALID_ARGUMENT);
    EXPECT_EQ(nfd_job_wait(job, UINT64_MAX), NFD_JOB_DONE);
    nfd_job_destroy(job);
    nfd_asset_destroy(a);

    job = submit(mo);
    EXPECT_EQ(nfd_job_feed(job, nullptr, 1, nullptr), NFD_ERROR_INVALID_ARGUMENT);
    EXPECT_EQ(nfd_job_poll(job), NFD_JOB_WAITING_FOR_INPUT);  // unchanged
    nfd_job_destroy(job);
}

}  // namespace
}  // namespace nfd::test
