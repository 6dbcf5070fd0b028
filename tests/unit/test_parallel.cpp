// parallel_for over the persistent pool: every index once, any thread count,
// nested loops, exceptions, and loops started from several threads at once.
#include <gtest/gtest.h>

#include <sys/resource.h>
#include <sys/syscall.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <chrono>
#include <mutex>
#include <set>
#include <tuple>
#include <stdexcept>
#include <thread>
#include <vector>

#include "appliance/core/parallel.hpp"

namespace glint {
namespace {

TEST(ParallelFor, EveryIndexRunsExactlyOnceForAnyThreadCount) {
    for (int threads : {1, 2, 3, 8}) {
        std::vector<std::atomic<int>> hits(1000);
        parallel_for(1000, threads, [&](int i) { hits[std::size_t(i)].fetch_add(1); });
        for (const auto& h : hits) ASSERT_EQ(h.load(), 1) << threads << " threads";
    }
}

TEST(ParallelFor, EmptyAndSingleLoops) {
    int calls = 0;
    parallel_for(0, 4, [&](int) { ++calls; });
    parallel_for(-3, 4, [&](int) { ++calls; });
    EXPECT_EQ(calls, 0);
    parallel_for(1, 4, [&](int i) { calls += i + 1; });
    EXPECT_EQ(calls, 1);
}

TEST(ParallelFor, NestedLoopRunsOnTheBodysThread) {
    std::atomic<long> total{0};
    parallel_for(8, 2, [&](int i) {
        const auto outer = std::this_thread::get_id();
        parallel_for(10, 2, [&](int j) {
            EXPECT_EQ(std::this_thread::get_id(), outer);
            total += i * 10 + j;
        });
    });
    EXPECT_EQ(total.load(), 79 * 80 / 2);
}

TEST(ParallelFor, ExceptionReachesTheCallerAndThePoolStaysUsable) {
    EXPECT_THROW(parallel_for(100, 2,
                              [](int i) {
                                  if (i == 37) throw std::runtime_error("row 37");
                              }),
                 std::runtime_error);
    std::atomic<int> count{0};
    parallel_for(100, 2, [&](int) { ++count; });
    EXPECT_EQ(count.load(), 100);
}

TEST(ParallelFor, LoopsFromSeveralThreadsTakeTurns) {
    std::atomic<long> total{0};
    std::vector<std::thread> callers;
    for (int c = 0; c < 4; ++c)
        callers.emplace_back([&] {
            for (int rep = 0; rep < 20; ++rep) parallel_for(50, 2, [&](int i) { total += i; });
        });
    for (auto& t : callers) t.join();
    EXPECT_EQ(total.load(), 4L * 20 * (49 * 50 / 2));
}

int this_thread_nice() {
    errno = 0;
    return getpriority(PRIO_PROCESS, static_cast<id_t>(syscall(SYS_gettid)));
}

// Background work (the kiosk's shadow bake, the final maps' CPU parts) must not take the cores
// from the frames through the pool: a lowered thread's loop runs on workers lowered as well, and
// a normal thread's loop still on workers at its own priority.
TEST(ParallelFor, ALoweredThreadsLoopRunsOnLoweredWorkers) {
    const int caller_nice = this_thread_nice();
    const auto nice_levels = [](int threads) {
        std::mutex m;
        std::set<int> levels;
        std::set<std::thread::id> ids;
        parallel_for(200, threads, [&](int) {
            const int n = this_thread_nice();
            std::this_thread::sleep_for(std::chrono::microseconds(200));  // every worker gets some
            std::lock_guard lock(m);
            levels.insert(n);
            ids.insert(std::this_thread::get_id());
        });
        return std::make_pair(levels, ids.size());
    };
    std::set<int> background;
    std::size_t background_threads = 0;
    std::thread([&] {
        ASSERT_TRUE(lower_this_thread_priority());
        std::tie(background, background_threads) = nice_levels(3);
    }).join();
    EXPECT_GT(background_threads, 1u);  // the pool's workers took part
    EXPECT_EQ(background, std::set<int>{10});
    const auto [foreground, foreground_threads] = nice_levels(3);
    EXPECT_GT(foreground_threads, 1u);
    EXPECT_EQ(foreground, std::set<int>{caller_nice});
}

}  // namespace
}  // namespace glint
