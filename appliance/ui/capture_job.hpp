// The kiosk's capture (docs/kiosk.md, "Capture and processing"): the capture pipeline
// (capture/capture_pipeline.hpp, the same code as `glint capture`) on a worker thread, fed frame by
// frame by the kiosk's frame loop through a FeedCamera. While the scan runs the worker accumulates
// each frame, corrects its drift and keeps the online adjustment, and publishes the guide's step
// and the coverage (the arrow, the minimap, the progress); after finish() it completes the
// adjusted map and saves it. The frame loop never waits for it, except in a deterministic replay
// (wait_for()).
#pragma once

#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <exception>
#include <memory>
#include <mutex>
#include <optional>
#include <thread>
#include <vector>

#include "appliance/capture/camera_source.hpp"
#include "appliance/capture/capture_pipeline.hpp"

namespace glint::ui {

// A camera source whose frames are handed to it by another thread (the kiosk's frame loop).
class FeedCamera final : public capture::CameraSource {
public:
    std::string describe() const override { return "feed: the kiosk's frames"; }
    void start() override {}
    void stop() override {}
    std::optional<capture::CameraFrame> next_frame(std::chrono::milliseconds timeout) override;
    void set_exposure(const capture::ExposureRequest&) override {}  // the kiosk's camera decides
    bool finished() const override;
    capture::CameraHealth health() const override;

    void push(capture::CameraFrame frame);
    void close();  // no more frames: finished() once the queue is empty

private:
    mutable std::mutex mutex_;
    std::condition_variable ready_;
    std::deque<capture::CameraFrame> queue_;
    bool closed_ = false;
    std::uint64_t delivered_ = 0;
};

// What the scan looks like now (copied out under a lock).
struct CaptureLiveStatus {
    capture::GuidedStep step;
    glm::dquat world_from_camera{1, 0, 0, 0};
    bool has_step = false;
    // Coverage on a small equirect for the minimap: 0 unseen .. 255 seen by 4 or more frames.
    int minimap_width = 64, minimap_height = 32;
    std::vector<std::uint8_t> minimap;
};

class CaptureJob {
public:
    // options.session: the session whose calibration and sensor stream the frames go with (the
    // replayed one, or the live recording); options.out: where the map is saved.
    explicit CaptureJob(capture::CaptureOptions options);
    // Closes the feed and joins. A job still finishing its map is cancelled first: the worker
    // stops at its next progress step (one frame of the final map), so that SIGTERM or a
    // timeout does not wait for a map nobody will see.
    ~CaptureJob();
    CaptureJob(const CaptureJob&) = delete;
    CaptureJob& operator=(const CaptureJob&) = delete;

    void push(const capture::CameraFrame& frame);  // frame thread
    void finish();                                 // the scan is over
    // Blocks until the worker has taken in every frame pushed so far (deterministic replays).
    void wait_for_frames();

    CaptureLiveStatus live() const;
    // After finish(): 0..1 of the work after the last frame (the adjusted map), estimated.
    double finishing_progress() const;
    bool done() const { return done_.load(); }
    // The summary once done (rethrows the worker's error); nullopt before.
    std::optional<capture::CaptureSummary> take();
    std::size_t pushed() const { return pushed_; }
    // Wall time from finish() to the saved map (seconds), when done.
    double finishing_seconds() const { return finishing_seconds_; }

private:
    void on_progress(long long done, long long total);

    capture::CaptureOptions options_;
    FeedCamera feed_;
    std::size_t pushed_ = 0;
    std::atomic<long long> progress_{0};
    std::atomic<bool> cancelled_{false};
    long long progress_at_finish_ = -1;
    std::size_t used_at_finish_ = 0;
    mutable std::mutex mutex_;
    std::condition_variable progressed_;
    CaptureLiveStatus live_;
    std::atomic<bool> done_{false};
    bool taken_ = false;
    std::optional<capture::CaptureSummary> summary_;
    std::exception_ptr error_;
    std::chrono::steady_clock::time_point finish_at_;
    double finishing_seconds_ = 0;
    std::thread worker_;
};

}  // namespace glint::ui
