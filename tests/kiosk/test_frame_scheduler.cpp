// The frame budget's bookkeeping (appliance/ui/frame_scheduler.hpp): quantiles by nearest rank,
// times per state, the hard cap, and time left out of a frame.
#include <gtest/gtest.h>

#include <chrono>
#include <thread>

#include "appliance/ui/frame_scheduler.hpp"

namespace glint::ui {
namespace {

TEST(FrameTimes, QuantilesByNearestRank) {
    FrameTimes t;
    for (int i = 1; i <= 100; ++i) t.ms.push_back(double(101 - i));  // 100 .. 1, unsorted on purpose
    EXPECT_DOUBLE_EQ(t.median(), 50);
    EXPECT_DOUBLE_EQ(t.p99(), 99);
    EXPECT_DOUBLE_EQ(t.max(), 100);
    FrameTimes few;
    few.ms = {3, 1, 2};
    EXPECT_DOUBLE_EQ(few.p99(), 3);  // under 100 frames p99 is the largest
    EXPECT_DOUBLE_EQ(few.median(), 2);
    EXPECT_DOUBLE_EQ(FrameTimes{}.max(), 0);
}

TEST(FrameScheduler, KeepsTimesPerStateCountsTheHardCapAndLeavesOutExcludedTime) {
    FrameScheduler s(20.0, 15.0);
    s.begin_frame(KioskState::Capture);
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
    s.mark(FramePhase::Camera);
    EXPECT_GT(s.left_ms(), 0);
    EXPECT_LT(s.left_ms(), 20);
    const double a = s.end_frame();
    EXPECT_GE(a, 2);

    s.begin_frame(KioskState::Ar);
    std::this_thread::sleep_for(std::chrono::milliseconds(30));
    s.exclude_since_mark();  // a replay's wait: not the appliance's time
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
    s.mark(FramePhase::Render);
    const double b = s.end_frame();
    EXPECT_LT(b, 15);  // the 30 ms were left out
    EXPECT_EQ(s.over_cap(), 0);

    s.begin_frame(KioskState::Ar);
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
    s.mark(FramePhase::Render);
    EXPECT_DOUBLE_EQ(s.left_ms(), 0);  // over budget: nothing left for the background
    s.end_frame();
    EXPECT_EQ(s.over_cap(), 1);
    EXPECT_EQ(s.frames(), 3);
    ASSERT_EQ(s.by_state().size(), 2u);
    EXPECT_EQ(s.by_state().at(KioskState::Ar).ms.size(), 2u);
    EXPECT_EQ(s.by_state().at(KioskState::Capture).ms.size(), 1u);
    const auto means = s.phase_means();
    EXPECT_GT(means[int(FramePhase::Render)], 5);
    EXPECT_GT(means[int(FramePhase::Camera)], 0);
}

TEST(FrameTimes, AKioskRunningForMonthsKeepsAFixedWindow) {
    FrameTimes t;
    for (int k = 0; k < 70000; ++k) t.add(k < 60000 ? 1000.0 : 10.0);  // the old slow frames roll out
    EXPECT_EQ(t.count, 70000u);
    EXPECT_EQ(t.ms.size(), FrameTimes::kWindow);
    EXPECT_DOUBLE_EQ(t.median(), 1000.0);  // 55,536 of the window's frames are the old ones
    for (int k = 0; k < 60000; ++k) t.add(10.0);
    EXPECT_DOUBLE_EQ(t.max(), 10.0);
    EXPECT_EQ(t.ms.size(), FrameTimes::kWindow);

    FrameScheduler live(33.3, 100, /*keep_records=*/false);
    for (int k = 0; k < 10; ++k) {
        live.begin_frame(KioskState::Attract);
        live.end_frame();
    }
    EXPECT_EQ(live.frames(), 10);
    EXPECT_TRUE(live.records().empty());
    EXPECT_EQ(live.all().count, 10u);
}

}  // namespace
}  // namespace glint::ui
