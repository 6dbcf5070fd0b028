// Fork-join parallel loop with dynamic scheduling and exception propagation.
#include "appliance/core/parallel.hpp"

#include <algorithm>
#include <atomic>
#include <exception>
#include <mutex>
#include <thread>
#include <vector>

namespace glint {

int hardware_threads() { return std::max(1, int(std::thread::hardware_concurrency())); }

void parallel_for(int count, int threads, const std::function<void(int)>& body) {
    if (count <= 0) return;
    threads = std::clamp(threads, 1, count);
    std::atomic<int> next{0};
    std::exception_ptr failure;
    std::mutex failure_mutex;
    auto worker = [&] {
        for (;;) {
            const int i = next.fetch_add(1, std::memory_order_relaxed);
            if (i >= count) return;
            try {
                body(i);
            } catch (...) {
                std::lock_guard lock(failure_mutex);
                if (!failure) failure = std::current_exception();
                next.store(count);  // stop handing out work
                return;
            }
        }
    };
    std::vector<std::thread> pool;
    pool.reserve(std::size_t(threads - 1));
    for (int t = 1; t < threads; ++t) pool.emplace_back(worker);
    worker();
    for (auto& t : pool) t.join();
    if (failure) std::rethrow_exception(failure);
}

}  // namespace glint
