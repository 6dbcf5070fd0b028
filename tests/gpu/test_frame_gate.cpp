// FrameBudgetGate: a job on another thread gets only the slices granted to
// it, stops at cancel(), and never holds up a frame past its slice.
#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <thread>

#include "appliance/convolution/gpu/frame_gate.hpp"

namespace glint::convolution::gpu {
namespace {

using Clock = std::chrono::steady_clock;

TEST(FrameBudgetGate, JobRunsOnlyInsideGrantedSlices) {
    FrameBudgetGate gate(0.5);
    std::atomic<int> tiles{0};
    std::atomic<bool> in_slice{false};
    std::atomic<int> outside{0};
    std::thread job([&] {
        try {
            for (int k = 0; k < 12; ++k) {
                const double allowance = gate.acquire();
                if (!in_slice) ++outside;
                EXPECT_GE(allowance, 0.5);
                // Each "tile" reports 1 s, so that the slices' wall-clock deadlines
                // (3 s) never decide the outcome on a loaded machine.
                gate.spent(1000.0);
                ++tiles;
            }
        } catch (const JobCancelled&) {
        }
        gate.finish();
    });
    // Slices of 3 s: three tiles each; four slices run the 12 tiles.
    for (int frame = 0; frame < 4; ++frame) {
        in_slice = true;
        gate.run_slice(3000.0);
        in_slice = false;
        EXPECT_EQ(tiles.load(), 3 * (frame + 1)) << "frame " << frame;
    }
    job.join();
    EXPECT_EQ(outside.load(), 0);
}

TEST(FrameBudgetGate, CancelEndsTheJobAtItsNextTile) {
    FrameBudgetGate gate(0.5);
    std::atomic<bool> cancelled{false};
    std::atomic<int> tiles{0};
    std::atomic<double> first_allowance{-1.0};
    std::thread job([&] {
        try {
            for (;;) {
                const double allowance = gate.acquire();
                if (tiles == 0) first_allowance = allowance;
                // Tiles report 1 s against a 2 s slice (as above: the slice's wall-clock
                // deadline never decides the outcome): exactly two fit.
                gate.spent(1000.0);
                ++tiles;
            }
        } catch (const JobCancelled&) {
            cancelled = true;
        }
        gate.finish();
    });
    gate.run_slice(2000.0);
    EXPECT_EQ(tiles.load(), 2) << "the slice's allowance";
    gate.cancel();
    job.join();
    EXPECT_TRUE(cancelled.load());
    EXPECT_EQ(first_allowance.load(), 2000.0) << "the first tile is offered the whole slice";
    // No tile after cancel(), and a finished job gives a slice back at once: a slice of 10^9 ms
    // (11 days) that waited for the job would hang the test (ctest's timeout fails it).
    gate.run_slice(1e9);
    EXPECT_EQ(tiles.load(), 2);
}

TEST(FrameBudgetGate, BusyJobDoesNotHoldTheFramePastItsSlice) {
    FrameBudgetGate gate(0.5);
    std::atomic<bool> stop{false};
    std::thread job([&] {
        try {
            gate.acquire();
            // CPU work between passes, without asking for a tile.
            while (!stop) std::this_thread::sleep_for(std::chrono::milliseconds(1));
            gate.acquire();
        } catch (const JobCancelled&) {
        }
        gate.finish();
    });
    gate.run_slice(1.0);  // the job takes the slice, then works on the CPU
    const auto start = Clock::now();
    gate.run_slice(5.0);
    const double waited = std::chrono::duration<double, std::milli>(Clock::now() - start).count();
    EXPECT_LT(waited, 1000.0) << "the render thread must get its frame back";
    stop = true;
    gate.cancel();
    job.join();
}

}  // namespace
}  // namespace glint::convolution::gpu
