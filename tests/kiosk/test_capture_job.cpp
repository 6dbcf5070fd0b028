// The kiosk's frame feed into the capture pipeline (appliance/ui/capture_job.hpp): frames in order,
// a wait that ends with a frame or the timeout, and the end of the stream once closed and drained.
#include <gtest/gtest.h>

#include <chrono>
#include <thread>

#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <memory>

#include "appliance/capture/kiosk_session.hpp"
#include "appliance/capture/session.hpp"
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

namespace glint::ui {
namespace {

// A job dropped after its last frame (SIGTERM, a timeout) stops at its next progress step
// instead of finishing and saving a map nobody will see; one that is finished saves it. On the
// shipped session's first 40 scan frames.
TEST(CaptureJob, ADroppedJobDoesNotFinishItsMap) {
    const std::filesystem::path session_dir = std::filesystem::path(GLINT_SOURCE_DIR) / "data/sessions/kiosk";
    const capture::Session session = capture::open_session(session_dir);
    const std::optional<capture::KioskSessionInfo> info = capture::load_kiosk_info(session);
    ASSERT_TRUE(info && info->phase("scan"));
    const auto run = [&](bool drop) {
        capture::CaptureOptions o;
        o.session = session_dir;
        o.out = std::filesystem::temp_directory_path() /
                ("glint-capture-job-" + std::to_string(::getpid()) + (drop ? "-dropped" : "-finished") + ".exr");
        o.width = 256;
        o.height = 128;
        o.threads = 1;
        std::filesystem::remove(o.out);
        auto job = std::make_unique<CaptureJob>(o);
        int pushed = 0;
        for (const capture::FrameRecord& r : session.frames) {
            if (r.t_ns < info->phase("scan")->start_ns) continue;
            capture::CameraFrame f = capture::load_frame(session, r);
            f.sequence = r.index;
            job->push(f);
            if (++pushed == 40) break;
        }
        job->wait_for_frames();  // the live pass has taken every frame in
        if (drop) {
            job.reset();  // cancels, closes the feed, joins
        } else {
            job->finish();
            while (!job->done()) std::this_thread::sleep_for(std::chrono::milliseconds(1));
            EXPECT_TRUE(job->take().has_value());
        }
        const bool saved = std::filesystem::exists(o.out);
        std::filesystem::remove(o.out);
        std::filesystem::remove(capture::coverage_path_for(o.out));
        return saved;
    };
    EXPECT_TRUE(run(false));
    EXPECT_FALSE(run(true));
}

}  // namespace
}  // namespace glint::ui
