// The asynchronous queue (queue.h). One mutex guards the whole queue: every operation under it is
// bookkeeping (a map insert or erase, counters), never a step or a callback, so a caller's call
// waits at most for another thread's bookkeeping. Steps and callbacks run with the lock released.
#include "queue.h"

#include <algorithm>
#include <chrono>
#include <exception>
#include <iterator>
#include <limits>
#include <set>
#include <new>
#include <stdexcept>

#include "parallel.h"

namespace nfd {

struct Job::Shared {
    std::mutex mutex;
    std::condition_variable work_changed;  // a job was queued, memory released, stopping
    std::map<std::pair<int64_t, uint64_t>, std::shared_ptr<Job>> pending;  // begin() runs next
    std::map<std::pair<int64_t, uint64_t>, std::shared_ptr<Job>> awaiting;  // waiting for input
    // The running jobs (a worker runs their steps), and those of them that wait for memory to
    // grow their reservation, by order.
    uint32_t running = 0;
    std::set<std::pair<int64_t, uint64_t>> growing;
    uint64_t submitted = 0;
    MemoryBytes budget, reserved, peak;
    uint64_t done = 0, failed = 0, cancelled = 0;
    bool stopping = false;

    static bool within(uint64_t bytes, uint64_t limit) { return limit == 0 || bytes <= limit; }
    bool fits_budget(const MemoryBytes& need) const {
        return within(need.host, budget.host) && within(need.device, budget.device);
    }
    // With `held` (the job's own reservation) given back first.
    bool fits_now(const MemoryBytes& need, const MemoryBytes& held) const {
        return within(reserved.host - held.host + need.host, budget.host) &&
               within(reserved.device - held.device + need.device, budget.device);
    }
    void set_reservation(Job& job, const MemoryBytes& bytes) {
        reserved.host = reserved.host - job.reserved_.host + bytes.host;
        reserved.device = reserved.device - job.reserved_.device + bytes.device;
        job.reserved_ = bytes;
        peak.host = std::max(peak.host, reserved.host);
        peak.device = std::max(peak.device, reserved.device);
    }

    // Makes `job` final: its memory is given back, then (lock released) its work and, unless it is
    // DONE, its mesh are freed (unmapping tens of MB takes milliseconds: not under the lock) and
    // its callback runs on this thread. Returns with the lock held again.
    void finish(const std::shared_ptr<Job>& job, nfd_job_status status, nfd_result result,
                std::unique_lock<std::mutex>& lock) {
        job->status_ = status;
        job->result_ = result;
        set_reservation(*job, MemoryBytes{});
        ++(status == NFD_JOB_DONE ? done : status == NFD_JOB_FAILED ? failed : cancelled);
        std::optional<MeshResult> dropped;
        if (status != NFD_JOB_DONE) dropped.swap(job->mesh_);
        std::unique_ptr<JobWork> work = std::move(job->work_);
        std::function<void(nfd_job_status)> callback = std::move(job->callback_);
        job->callback_ = nullptr;
        if (callback) {
            job->in_callback_ = true;
            job->callback_thread_ = std::this_thread::get_id();
        }
        job->changed_.notify_all();
        work_changed.notify_all();  // memory was released
        lock.unlock();
        work.reset();
        dropped.reset();
        if (callback) callback(status);
        lock.lock();
        if (callback) {
            job->in_callback_ = false;
            job->changed_.notify_all();
        }
    }

    // The callback of a running job that delivered a mesh, with RUNNING. It is moved out while it
    // runs, so that release() from inside it (the callback destroying its job) does not destroy
    // the function being called; it goes back unless release() came.
    void notify_delivery(Job& job, std::unique_lock<std::mutex>& lock) {
        if (!job.callback_) return;
        std::function<void(nfd_job_status)> callback = std::move(job.callback_);
        job.callback_ = nullptr;
        job.in_callback_ = true;
        job.callback_thread_ = std::this_thread::get_id();
        lock.unlock();
        callback(NFD_JOB_RUNNING);
        lock.lock();
        if (!job.released_) job.callback_ = std::move(callback);
        job.in_callback_ = false;
        job.changed_.notify_all();
    }

    void cancel_pending(const std::shared_ptr<Job>& job, std::unique_lock<std::mutex>& lock) {
        pending.erase(job->order_);
        work_changed.notify_all();  // the head may have changed
        finish(job, NFD_JOB_CANCELLED, NFD_ERROR_CANCELLED, lock);
    }

    // Ends a job that has not started (its callback on this thread): a pending one is cancelled,
    // one waiting for input ends with `status`. A copy of the map's pointer keeps it alive.
    void end_unstarted(Job& job, nfd_job_status status, nfd_result result,
                       std::unique_lock<std::mutex>& lock) {
        if (job.status_ != NFD_JOB_WAITING_FOR_INPUT) {
            const std::shared_ptr<Job> self = pending.at(job.order_);
            return cancel_pending(self, lock);
        }
        const std::shared_ptr<Job> self = awaiting.at(job.order_);
        awaiting.erase(job.order_);
        finish(self, status, result, lock);
    }

    // Inserts `job` among the pending ones; a job that goes before one waiting for memory takes
    // its place: that one is queued again.
    void add_pending(const std::shared_ptr<Job>& job) {
        const auto at = pending.emplace(job->order_, job).first;
        const auto behind = std::next(at);
        if (at == pending.begin() && behind != pending.end()) behind->second->status_ = NFD_JOB_QUEUED;
    }
};

namespace {

// Not yet running, and ended at once by a cancel.
bool is_pending(nfd_job_status s) {
    return s == NFD_JOB_QUEUED || s == NFD_JOB_WAITING_FOR_MEMORY || s == NFD_JOB_WAITING_FOR_INPUT;
}
bool is_final(nfd_job_status s) {
    return s == NFD_JOB_DONE || s == NFD_JOB_FAILED || s == NFD_JOB_CANCELLED;
}

// As api.cpp's guard: nothing may escape a worker thread (std::terminate would end the host).
nfd_result run_step(JobWork& work, StepResult* out) noexcept {
    try {
        return work.step(out);
    } catch (const std::bad_alloc&) {
        return NFD_ERROR_OUT_OF_MEMORY;
    } catch (const std::length_error&) {
        return NFD_ERROR_OUT_OF_MEMORY;
    } catch (...) {
        return NFD_ERROR_INTERNAL;
    }
}

}  // namespace

// ---- Job ----------------------------------------------------------------------------------------

Job::Job(std::shared_ptr<Shared> shared, std::unique_ptr<JobWork> work, int32_t priority,
         std::function<void(nfd_job_status)> callback)
    : shared_(std::move(shared)), work_(std::move(work)), callback_(std::move(callback)),
      order_(-int64_t(priority), 0) {}

// A job is final to its handle once its callback has returned, so that what the callback did is
// visible to whoever sees the final status.
nfd_job_status Job::status() const {
    std::lock_guard<std::mutex> lock(shared_->mutex);
    return in_callback_ ? NFD_JOB_RUNNING : status_;
}

Job::Progress Job::progress() const {
    std::lock_guard<std::mutex> lock(shared_->mutex);
    return progress_;
}

nfd_job_status Job::wait(uint64_t timeout_ns) {
    std::unique_lock<std::mutex> lock(shared_->mutex);
    auto final_ = [this] { return is_final(status_) && !in_callback_; };
    if (timeout_ns == std::numeric_limits<uint64_t>::max()) {
        changed_.wait(lock, final_);
    } else {
        // Capped so that now() + timeout cannot overflow the clock (292 years at int64 ns).
        const uint64_t cap = uint64_t(std::numeric_limits<int64_t>::max() / 4);
        changed_.wait_for(lock, std::chrono::nanoseconds(int64_t(std::min(timeout_ns, cap))),
                          final_);
    }
    return in_callback_ ? NFD_JOB_RUNNING : status_;
}

void Job::cancel() {
    std::unique_lock<std::mutex> lock(shared_->mutex);
    if (is_pending(status_)) {
        shared_->end_unstarted(*this, NFD_JOB_CANCELLED, NFD_ERROR_CANCELLED, lock);
    } else if (status_ == NFD_JOB_RUNNING) {
        cancel_requested_ = true;
        shared_->work_changed.notify_all();  // its worker may be waiting for memory
    }
}

std::optional<MeshResult> Job::take_mesh(nfd_result* result) {
    std::lock_guard<std::mutex> lock(shared_->mutex);
    *result = result_;
    std::optional<MeshResult> mesh = std::move(mesh_);
    mesh_.reset();
    if (mesh) progress_.taken_mesh_resolution = progress_.newest_mesh_resolution;
    return mesh;
}

void Job::release() {
    std::optional<MeshResult> mesh;
    {
        std::unique_lock<std::mutex> lock(shared_->mutex);
        callback_ = nullptr;
        released_ = true;
        if (is_pending(status_)) {
            shared_->end_unstarted(*this, NFD_JOB_CANCELLED, NFD_ERROR_CANCELLED, lock);
        } else if (status_ == NFD_JOB_RUNNING) {
            cancel_requested_ = true;  // the worker frees the work after the step in progress
            shared_->work_changed.notify_all();  // or at once if it waits for memory
        }
        // A callback of this job running on another thread may still use the handle: wait for
        // it. From inside the callback itself (it may destroy its own job) there is nothing to
        // wait for.
        changed_.wait(lock, [this] {
            return !in_callback_ || callback_thread_ == std::this_thread::get_id();
        });
        mesh = std::move(mesh_);
        mesh_.reset();
    }
}

bool Job::start(std::unique_ptr<JobWork> work) {
    {
        std::lock_guard<std::mutex> lock(shared_->mutex);
        if (status_ != NFD_JOB_WAITING_FOR_INPUT) return false;  // `work` is freed unlocked
        const auto node = shared_->awaiting.extract(order_);
        work_ = std::move(work);
        status_ = NFD_JOB_QUEUED;
        shared_->add_pending(node.mapped());
    }
    shared_->work_changed.notify_all();
    return true;
}

bool Job::awaiting_input() const {
    std::lock_guard<std::mutex> lock(shared_->mutex);
    return status_ == NFD_JOB_WAITING_FOR_INPUT;
}

void Job::fail_input(nfd_result result) {
    std::unique_lock<std::mutex> lock(shared_->mutex);
    if (status_ == NFD_JOB_WAITING_FOR_INPUT) shared_->end_unstarted(*this, NFD_JOB_FAILED, result, lock);
}

// ---- Queue --------------------------------------------------------------------------------------

Queue::Queue(uint32_t workers, MemoryBytes budget)
    : shared_(std::make_shared<Job::Shared>()) {
    shared_->budget = budget;
    const uint32_t count = std::max(1u, workers);
    workers_.reserve(count);
    try {
        for (uint32_t i = 0; i < count; ++i)
            workers_.emplace_back([this] {
                run_as_background_thread();
                run_worker();
            });
    } catch (...) {
        {
            std::lock_guard<std::mutex> lock(shared_->mutex);
            shared_->stopping = true;
        }
        shared_->work_changed.notify_all();
        for (std::thread& t : workers_) t.join();
        throw;
    }
}

Queue::~Queue() {
    {
        std::unique_lock<std::mutex> lock(shared_->mutex);
        shared_->stopping = true;
        shared_->work_changed.notify_all();
        // finish() releases the lock for callbacks, during which the map may change: take the
        // first entry again every time.
        while (!shared_->pending.empty()) {
            const std::shared_ptr<Job> job = shared_->pending.begin()->second;
            shared_->cancel_pending(job, lock);
        }
        while (!shared_->awaiting.empty())
            shared_->end_unstarted(*shared_->awaiting.begin()->second, NFD_JOB_CANCELLED,
                                 NFD_ERROR_CANCELLED, lock);
    }
    for (std::thread& t : workers_) t.join();
}

bool Queue::submit(std::unique_ptr<JobWork> work, int32_t priority,
                   std::function<void(nfd_job_status)> callback, std::shared_ptr<Job>* out) {
    return enqueue(std::shared_ptr<Job>(new Job(shared_, std::move(work), priority, std::move(callback))),
                   true, out);
}

bool Queue::submit_awaiting(int32_t priority, std::function<void(nfd_job_status)> callback,
                            std::shared_ptr<Job>* out) {
    return enqueue(std::shared_ptr<Job>(new Job(shared_, nullptr, priority, std::move(callback))),
                   false, out);
}

bool Queue::enqueue(std::shared_ptr<Job> job, bool pending, std::shared_ptr<Job>* out) {
    {
        std::lock_guard<std::mutex> lock(shared_->mutex);
        if (shared_->stopping) return false;
        job->order_.second = shared_->submitted++;
        if (pending) {
            shared_->add_pending(job);
        } else {
            job->status_ = NFD_JOB_WAITING_FOR_INPUT;
            shared_->awaiting.emplace(job->order_, job);
        }
        *out = std::move(job);
    }
    // All workers: the one woken may be waiting for memory that a higher-priority job may use.
    if (pending) shared_->work_changed.notify_all();
    return true;
}

nfd_queue_stats Queue::stats() const {
    std::lock_guard<std::mutex> lock(shared_->mutex);
    const Job::Shared& s = *shared_;
    nfd_queue_stats out{};
    out.jobs_submitted = s.submitted;
    out.jobs_done = s.done;
    out.jobs_failed = s.failed;
    out.jobs_cancelled = s.cancelled;
    out.reserved_host_bytes = s.reserved.host;
    out.reserved_device_bytes = s.reserved.device;
    out.peak_reserved_host_bytes = s.peak.host;
    out.peak_reserved_device_bytes = s.peak.device;
    return out;
}

void Queue::run_worker() {
    std::unique_lock<std::mutex> lock(shared_->mutex);
    while (std::shared_ptr<Job> job = next_job(lock)) run_steps(job, lock);
}

// The first pending job once its first step fits the budget (it is RUNNING and reserved on
// return), or nullptr when the queue stops. Strict order: while the head waits for memory no
// later job starts, so a large job cannot be starved by a stream of small ones. And no job starts
// while a running one waits to grow: the memory that is released goes to jobs that already hold
// some (they finish and release it all) before jobs that hold none take it.
std::shared_ptr<Job> Queue::next_job(std::unique_lock<std::mutex>& lock) {
    Job::Shared& s = *shared_;
    for (;;) {
        if (s.stopping) return nullptr;
        if (s.pending.empty() || !s.growing.empty()) {
            s.work_changed.wait(lock);
            continue;
        }
        const std::shared_ptr<Job> job = s.pending.begin()->second;
        const MemoryBytes need = job->work_->next_step_bytes();
        if (!s.fits_budget(need)) {  // would wait forever: fail it instead
            s.pending.erase(s.pending.begin());
            s.finish(job, NFD_JOB_FAILED, NFD_ERROR_LIMIT_EXCEEDED, lock);
            continue;
        }
        if (!s.fits_now(need, job->reserved_)) {
            job->status_ = NFD_JOB_WAITING_FOR_MEMORY;
            s.work_changed.wait(lock);
            continue;
        }
        s.pending.erase(s.pending.begin());
        s.set_reservation(*job, need);
        job->status_ = NFD_JOB_RUNNING;
        ++s.running;
        return job;
    }
}

// Runs the job's steps until it is final or restarts. Between steps the job keeps its reservation
// and, if cancelled (or the queue stops), ends there; the next step's reservation replaces the
// last one.
//
// A step that does not fit yet waits here, on its worker, holding the job's reservation. Two
// running jobs that both wait would wait forever (neither releases): when every running job waits
// and none fits, the last of them in the queue's order restarts: it gives back all it holds and
// goes back to pending at its place. The first in order never restarts while another job holds
// memory, and alone it fits (or its step is over the whole budget, and it fails): it finishes,
// so every job does, one after the other in the worst case. A restarted job evaluates its levels
// again; a queue of one worker never restarts a job.
void Queue::run_steps(const std::shared_ptr<Job>& job, std::unique_lock<std::mutex>& lock) {
    Job::Shared& s = *shared_;
    auto end = [&](nfd_job_status status, nfd_result result) {
        --s.running;
        s.finish(job, status, result, lock);
    };
    for (;;) {
        lock.unlock();
        StepResult step;
        const nfd_result r = run_step(*job->work_, &step);
        lock.lock();
        job->progress_.levels_done = std::max(job->progress_.levels_done, step.levels_done);
        // Meshes are freed outside the lock: one this step replaced here, one nobody will take
        // in finish().
        const bool delivered = step.mesh.has_value();
        if (delivered) {
            job->mesh_.swap(step.mesh);
            job->progress_.newest_mesh_resolution = step.mesh_resolution;
            if (step.mesh) {
                lock.unlock();
                step.mesh.reset();
                lock.lock();
            }
        }
        // A cancel that came during the step wins over its outcome, the last step's included:
        // the caller no longer wants the mesh.
        if (job->cancel_requested_ || s.stopping) return end(NFD_JOB_CANCELLED, NFD_ERROR_CANCELLED);
        if (r != NFD_SUCCESS) return end(NFD_JOB_FAILED, r);
        if (step.finished) return end(NFD_JOB_DONE, NFD_SUCCESS);
        if (delivered) {
            s.notify_delivery(*job, lock);
            if (job->cancel_requested_ || s.stopping)
                return end(NFD_JOB_CANCELLED, NFD_ERROR_CANCELLED);
        }
        const MemoryBytes need = job->work_->next_step_bytes();
        if (!s.fits_budget(need)) return end(NFD_JOB_FAILED, NFD_ERROR_LIMIT_EXCEEDED);
        if (!s.fits_now(need, job->reserved_)) {
            s.growing.insert(job->order_);
            s.work_changed.notify_all();  // the running jobs may now all be waiting
            s.work_changed.wait(lock, [&] {
                const bool all_wait = s.growing.size() == s.running;
                return s.fits_now(need, job->reserved_) || job->cancel_requested_ || s.stopping ||
                       (all_wait && *s.growing.rbegin() == job->order_);
            });
            s.growing.erase(job->order_);
            s.work_changed.notify_all();  // pending jobs may start again
            if (job->cancel_requested_ || s.stopping)
                return end(NFD_JOB_CANCELLED, NFD_ERROR_CANCELLED);
            if (!s.fits_now(need, job->reserved_)) return restart(job, lock);
        }
        s.set_reservation(*job, need);
    }
}

// The job gives back its memory and is pending again at its place in the order (run_steps). The
// work frees its state with the lock released; meanwhile the job still counts as running and
// holding its reservation, so that no other job sees the memory before it is free.
void Queue::restart(const std::shared_ptr<Job>& job, std::unique_lock<std::mutex>& lock) {
    Job::Shared& s = *shared_;
    lock.unlock();
    job->work_->restart();
    lock.lock();
    --s.running;
    if (job->cancel_requested_ || s.stopping)
        return s.finish(job, NFD_JOB_CANCELLED, NFD_ERROR_CANCELLED, lock);
    s.set_reservation(*job, MemoryBytes{});
    job->status_ = NFD_JOB_QUEUED;
    s.pending.emplace(job->order_, job);
    s.work_changed.notify_all();
}

}  // namespace nfd
