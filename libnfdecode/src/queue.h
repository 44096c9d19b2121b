// The asynchronous queue behind nfd_queue / nfd_job (nfdecode.h, "Asynchronous queue"): worker
// threads that run jobs as sequences of bounded steps, in priority order, within a memory budget.
// The queue knows nothing of what a step does (JobWork) nor of the C handles (api.cpp wraps it).
#pragma once
#include <condition_variable>
#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <set>
#include <thread>
#include <utility>
#include <vector>

#include "extract.h"
#include "mesh.h"
#include "nfdecode/nfdecode.h"

namespace nfd {

struct MemoryBytes {
    uint64_t host = 0;
    uint64_t device = 0;  // Vulkan buffer memory
};
inline MemoryBytes operator+(const MemoryBytes& a, const MemoryBytes& b) {
    return MemoryBytes{a.host + b.host, a.device + b.device};
}

struct MeshResult {
    MeshData data;
    ExtractStats stats;
};

struct StepResult {
    bool finished = false;           // no step left: the job is DONE
    std::optional<MeshResult> mesh;  // delivered by this step; replaces an untaken older one
    uint32_t mesh_resolution = 0;    // of `mesh`: cells per axis
    uint32_t levels_done = 0;        // progress after this step (nfd_job_progress)
};

// What a job does, cut into steps that each allocate a bounded amount and end at a point where
// the job may stop (cancellation) or wait (budget). One worker at a time runs a job's steps, one
// at a time; no two calls on one JobWork overlap.
//
// The implementation (ExtractWork, extract_work.h) has one step per grid level and delivers a mesh
// per level asked for. A job whose file is still arriving has no work yet (Queue::submit_awaiting):
// parsing stays on the feeding thread, and the job joins the pending ones once its asset is there.
class JobWork {
public:
    virtual ~JobWork() = default;
    // An upper bound of the memory the job holds at any moment of its next step, what it kept from
    // earlier steps included. Called under the queue's lock: constant time, no allocation.
    virtual MemoryBytes next_step_bytes() const = 0;
    // Runs the next step. A result other than NFD_SUCCESS fails the job with that result.
    virtual nfd_result step(StepResult* out) = 0;
    // Frees what the earlier steps kept: the next step starts the work over (meshes already
    // delivered are not delivered again). How the queue breaks a wait in which every running job
    // waits for memory (Queue::run_steps).
    virtual void restart() = 0;
};

class Queue;

// The state of one job, shared by its handle and the queue (either may go first). Every field is
// guarded by the queue's mutex.
class Job {
public:
    nfd_job_status status() const;
    nfd_job_status wait(uint64_t timeout_ns);
    void cancel();
    // The delivered mesh, if any (moved out); *result is the job's outcome (nfd_job_take_mesh):
    // NFD_ERROR_NOT_READY while it runs, whether or not a mesh is given.
    std::optional<MeshResult> take_mesh(nfd_result* result);
    struct Progress {
        uint32_t levels_done = 0, newest_mesh_resolution = 0, taken_mesh_resolution = 0;
    };
    Progress progress() const;
    // The handle lets go: no callback starts afterwards (waits for one running on another thread),
    // the job is cancelled if not final, the untaken mesh is freed.
    void release();
    // A job waiting for input (NFD_JOB_WAITING_FOR_INPUT) gets its work and joins the pending jobs
    // at its submission place; false (and `work` is dropped) if it is no longer waiting (cancelled).
    bool start(std::unique_ptr<JobWork> work);
    bool awaiting_input() const;
    // A job waiting for input fails with `result` (its input is unusable); its callback runs on
    // this thread. No effect on a job that started or is final.
    void fail_input(nfd_result result);

private:
    friend class Queue;
    struct Shared;  // the queue's lock and wait lists, which outlive the Queue object
    Job(std::shared_ptr<Shared> shared, std::unique_ptr<JobWork> work, int32_t priority,
        std::function<void(nfd_job_status)> callback);

    std::shared_ptr<Shared> shared_;
    std::unique_ptr<JobWork> work_;                // freed when the job becomes final
    std::function<void(nfd_job_status)> callback_; // moved out while it runs; cleared by release()
    bool released_ = false;                        // release() came: no callback any more
    std::pair<int64_t, uint64_t> order_;           // (-priority, submission number)
    nfd_job_status status_ = NFD_JOB_QUEUED;
    nfd_result result_ = NFD_ERROR_NOT_READY;
    bool cancel_requested_ = false;
    MemoryBytes reserved_;                         // counted in the queue's reservation now
    std::optional<MeshResult> mesh_;
    Progress progress_;
    std::thread::id callback_thread_;              // set while callback_ runs
    bool in_callback_ = false;
    std::condition_variable changed_;              // status final, callback returned
};

class Queue {
public:
    // `workers` threads (at least one; on a Vulkan device each job records its own batches, gpu/
    // job.cpp). A budget of 0 is unlimited. Throws std::bad_alloc (or std::system_error) when a
    // thread cannot start.
    Queue(uint32_t workers, MemoryBytes budget);
    // Cancels what has not finished (callbacks of pending jobs on this thread) and joins.
    ~Queue();
    Queue(const Queue&) = delete;
    Queue& operator=(const Queue&) = delete;

    // Queues a job and stores it in *out before any worker can see it (so that a callback may
    // read *out); false, with *out untouched, once the destructor has begun. `callback` runs once
    // per final status and, with RUNNING, after each step that delivered a mesh but not the last.
    bool submit(std::unique_ptr<JobWork> work, int32_t priority,
                std::function<void(nfd_job_status)> callback, std::shared_ptr<Job>* out);
    // As submit, for a job whose work comes later (Job::start): it waits for input, holding no
    // memory and no place among the pending jobs, but its order is fixed now.
    bool submit_awaiting(int32_t priority, std::function<void(nfd_job_status)> callback,
                         std::shared_ptr<Job>* out);
    nfd_queue_stats stats() const;

private:
    void run_worker();
    bool enqueue(std::shared_ptr<Job> job, bool pending, std::shared_ptr<Job>* out);
    std::shared_ptr<Job> next_job(std::unique_lock<std::mutex>& lock);
    void run_steps(const std::shared_ptr<Job>& job, std::unique_lock<std::mutex>& lock);
    void restart(const std::shared_ptr<Job>& job, std::unique_lock<std::mutex>& lock);

    std::shared_ptr<Job::Shared> shared_;
    std::vector<std::thread> workers_;
};

}  // namespace nfd
