// The workers of parallel.h's loops. Starting a std::thread per loop cost ~40 us a loop here,
// and a decode makes dozens of loops (bench/RESULTS.md, "0.13.7"); these threads start on first
// use, grow to the most a loop has asked for (kMaxWorkers at most) and then wait for loops.
// The pool is never destroyed: at exit its threads may still be running, and joining them could
// hang. A fork copies none of them, and the child would wait forever on the parent's lock or
// condition variables (glibc's broadcast waits for waiters the child does not have): the pool's
// lock is held across fork(), and the child gets a pool that starts no thread (starting threads
// after a multi-threaded fork is outside what POSIX allows and ThreadSanitizer supports): its
// loops run on their callers.
#include "parallel.h"

#include <pthread.h>
#include <sched.h>
#ifdef __linux__
#include <sys/resource.h>
#include <sys/syscall.h>
#include <unistd.h>
#endif

#include <condition_variable>
#include <deque>
#include <mutex>
#include <new>
#include <system_error>

namespace nfd {
namespace parallel_detail {
namespace {

constexpr unsigned kMaxWorkers = 255;

class Pool {
public:
    // pthread_atfork's handlers.
    void before_fork() { mutex_.lock(); }
    void after_fork_in_parent() { mutex_.unlock(); }
    void after_fork_in_child() {
        // Only the forking thread exists: it holds the lock, no one waits on the conditions.
        new (&mutex_) std::mutex;
        new (&wake_) std::condition_variable;
        new (&finished_) std::condition_variable;
        loops_.clear();  // a loop in flight belongs to a thread the child does not have
        started_ = kMaxWorkers;  // counts as started: grow() starts none
    }

    void run(Loop* loop, unsigned workers) {
        {
            std::lock_guard<std::mutex> lock(mutex_);
            grow(std::min(workers, kMaxWorkers));
            loops_.push_back(loop);
        }
        wake_.notify_all();
        take(loop);
        std::unique_lock<std::mutex> lock(mutex_);
        remove(loop);  // no worker joins it from now on
        finished_.wait(lock, [loop] { return loop->helpers == 0; });
    }

private:
    static void take(Loop* loop) {
        for (size_t s; (s = loop->next.fetch_add(1, std::memory_order_relaxed)) < loop->slices;)
            loop->run(loop->context, s);
    }
    void grow(unsigned workers) {  // under the lock
        while (started_ < workers) {
            try {
                std::thread(&Pool::work, this).detach();
            } catch (const std::system_error&) {
                return;  // the loops run on fewer threads
            }
            ++started_;
        }
    }
    void remove(Loop* loop) {  // under the lock
        const auto it = std::find(loops_.begin(), loops_.end(), loop);
        if (it != loops_.end()) loops_.erase(it);
    }
    void work() {
        run_as_background_thread();
        std::unique_lock<std::mutex> lock(mutex_);
        for (;;) {
            wake_.wait(lock, [this] { return !loops_.empty(); });
            Loop* loop = loops_.front();
            if (loop->next.load(std::memory_order_relaxed) >= loop->slices) {
                remove(loop);  // all taken: its caller waits only for the helpers inside
                continue;
            }
            ++loop->helpers;
            lock.unlock();
            take(loop);
            lock.lock();
            if (--loop->helpers == 0) finished_.notify_all();
        }
    }
    std::mutex mutex_;
    std::condition_variable wake_, finished_;
    std::deque<Loop*> loops_;
    unsigned started_ = 0;
};

Pool* g_pool = nullptr;

Pool& pool() {
    static Pool* const shared = [] {
        g_pool = new Pool;  // never destroyed (see above)
        pthread_atfork([] { g_pool->before_fork(); }, [] { g_pool->after_fork_in_parent(); },
                       [] { g_pool->after_fork_in_child(); });
        return g_pool;
    }();
    return *shared;
}

}  // namespace

void run_loop(Loop* loop, unsigned workers) { pool().run(loop, workers); }

}  // namespace parallel_detail

void run_as_background_thread() {
#ifdef SCHED_BATCH
    sched_param param{};
    param.sched_priority = 0;  // the only priority of SCHED_BATCH; no privilege needed
    pthread_setschedparam(pthread_self(), SCHED_BATCH, &param);  // refused: stays as it was
#endif
}

void run_as_lowest_priority_thread() {
    run_as_background_thread();
#ifdef __linux__
    // Linux's nice value is per thread (the thread's id as the process id).
    setpriority(PRIO_PROCESS, id_t(syscall(SYS_gettid)), 19);  // refused: stays as it was
#endif
}

}  // namespace nfd
