// Fork-join parallel loop over a persistent worker pool, with dynamic
// scheduling and exception propagation.
#include "appliance/core/parallel.hpp"

#include <algorithm>
#include <atomic>
#include <condition_variable>
#include <exception>
#include <memory>
#include <mutex>
#include <thread>
#include <vector>

namespace glint {
namespace {

thread_local bool in_parallel_body = false;
// Set by lower_this_thread_priority: this thread's loops go to the background pool.
thread_local bool background_thread = false;

// One loop handed to the workers.
struct Job {
    int count = 0;
    const std::function<void(int)>* body = nullptr;
    std::atomic<int> next{0};
    std::exception_ptr failure;
    std::mutex failure_mutex;

    void work() {
        in_parallel_body = true;
        for (;;) {
            const int i = next.fetch_add(1, std::memory_order_relaxed);
            if (i >= count) break;
            try {
                (*body)(i);
            } catch (...) {
                std::lock_guard lock(failure_mutex);
                if (!failure) failure = std::current_exception();
                next.store(count);  // stop handing out work
                break;
            }
        }
        in_parallel_body = false;
    }
};

class Pool {
public:
    explicit Pool(bool background) : background_(background) {}
    ~Pool() {
        {
            std::lock_guard lock(mutex_);
            stopping_ = true;
        }
        wake_.notify_all();
        for (std::thread& t : workers_) t.join();
    }

    void run(Job& job, int helpers) {
        std::lock_guard turn(submit_mutex_);  // one loop at a time
        {
            std::unique_lock lock(mutex_);
            while (int(workers_.size()) < helpers) {
                const std::size_t id = workers_.size();
                workers_.emplace_back([this, id] { worker_loop(id); });
            }
            job_ = &job;
            wanted_ = std::size_t(helpers);
            pending_ = helpers;
            ++generation_;
        }
        wake_.notify_all();
        job.work();
        std::unique_lock lock(mutex_);
        done_.wait(lock, [&] { return pending_ == 0; });
        job_ = nullptr;
    }

private:
    void worker_loop(std::size_t id) {
        if (background_) lower_this_thread_priority();
        unsigned long seen = 0;
        std::unique_lock lock(mutex_);
        for (;;) {
            wake_.wait(lock, [&] { return stopping_ || generation_ != seen; });
            if (stopping_) return;
            seen = generation_;
            if (id >= wanted_) continue;  // this loop asked for fewer threads
            Job* job = job_;
            lock.unlock();
            job->work();
            lock.lock();
            if (--pending_ == 0) done_.notify_one();
        }
    }

    std::mutex submit_mutex_;
    std::mutex mutex_;
    std::condition_variable wake_, done_;
    std::vector<std::thread> workers_;
    Job* job_ = nullptr;
    std::size_t wanted_ = 0;
    int pending_ = 0;
    unsigned long generation_ = 0;
    bool stopping_ = false;
    bool background_;
};

// Two pools: the loops of threads at normal priority (the capture, the scene's coarse maps), and
// those of background work (the shadow bake, the final maps' CPU parts), whose workers run at
// the lowered priority too. One pool for both let a background loop run on workers at normal
// priority, taking the cores from the frames (measured: a 58 ms render in the frame that started
// the room's shadow bake), and made a foreground loop wait for a background one.
Pool& pool(bool background) {
    static Pool foreground_pool(false), background_pool(true);
    return background ? background_pool : foreground_pool;
}

}  // namespace

int hardware_threads() { return std::max(1, int(std::thread::hardware_concurrency())); }

void parallel_for(int count, int threads, const std::function<void(int)>& body) {
    if (count <= 0) return;
    threads = std::clamp(threads, 1, count);
    Job job;
    job.count = count;
    job.body = &body;
    if (threads == 1 || in_parallel_body) {
        const bool outer = in_parallel_body;
        job.work();
        in_parallel_body = outer;
    } else {
        pool(background_thread).run(job, threads - 1);
    }
    if (job.failure) std::rethrow_exception(job.failure);
}

}  // namespace glint

#include <sys/resource.h>
#include <sys/syscall.h>
#include <unistd.h>

namespace glint {

bool lower_this_thread_priority() {
    // On Linux, nice applies per thread (the thread id as the "process").
    const auto tid = static_cast<id_t>(syscall(SYS_gettid));
    background_thread = true;
    return setpriority(PRIO_PROCESS, tid, 10) == 0;
}

}  // namespace glint
