// The kiosk's frame feed into the capture pipeline (appliance/ui/capture_job.hpp): frames in order,
// a wait that ends with a frame or the timeout, and the end of the stream once closed and drained.
#include <gtest/gtest.h>

#include <chrono>
#include <thread>

#include "appliance/ui/capture_job.hpp"

namespace glint::ui {
namespace {

capture::CameraFrame frame(std::uint64_t n) {
    capture::CameraFrame f;
    f.rgb = cv::Mat(4, 4, CV_8UC3, cv::Scalar(double(n), 0, 0));
    f.t_ns = std::int64_t(n) * 1000;
    f.sequence = n;
    return f;
}

TEST(FeedCamera, DeliversPushedFramesInOrderThenEndsWhenClosedAndDrained) {
    FeedCamera feed;
    EXPECT_FALSE(feed.finished());
    const auto t0 = std::chrono::steady_clock::now();
    EXPECT_FALSE(feed.next_frame(std::chrono::milliseconds(20)));  // nothing yet: the wait times out
    EXPECT_GE(std::chrono::steady_clock::now() - t0, std::chrono::milliseconds(15));
    feed.push(frame(1));
    feed.push(frame(2));
    feed.close();
    EXPECT_FALSE(feed.finished());  // two frames still to take
    auto a = feed.next_frame(std::chrono::milliseconds(0));
    auto b = feed.next_frame(std::chrono::milliseconds(0));
    ASSERT_TRUE(a && b);
    EXPECT_EQ(a->sequence, 1u);
    EXPECT_EQ(b->sequence, 2u);
    EXPECT_TRUE(feed.finished());
    EXPECT_FALSE(feed.next_frame(std::chrono::milliseconds(1000)));  // closed: no wait at all
    EXPECT_EQ(feed.health().frames, 2u);
}

TEST(FeedCamera, AWaitingReaderWakesForAFrameFromAnotherThread) {
    FeedCamera feed;
    std::thread producer([&] {
        std::this_thread::sleep_for(std::chrono::milliseconds(30));
        feed.push(frame(7));
    });
    const auto f = feed.next_frame(std::chrono::seconds(5));
    producer.join();
    ASSERT_TRUE(f);
    EXPECT_EQ(f->sequence, 7u);
}

TEST(CaptureJob, AnUnusableSessionIsReportedByTakeNotLost) {
    capture::CaptureOptions o;
    o.session = "/nonexistent/glint-session";
    o.out = "/tmp/glint-capture-job-never.exr";
    CaptureJob job(o);
    job.finish();
    for (int i = 0; i < 500 && !job.done(); ++i) std::this_thread::sleep_for(std::chrono::milliseconds(10));
    ASSERT_TRUE(job.done());
    EXPECT_THROW(job.take(), std::exception);
}

}  // namespace
}  // namespace glint::ui
