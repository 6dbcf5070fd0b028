// A camera source read on a thread of its own (docs/kiosk.md, "Live"): the kiosk's frame loop
// takes the frames that are ready and never waits inside a camera. A source that makes each frame
// when it falls due (the simulator renders it; a driver may block) would otherwise spend that time
// in the frame loop, and the watchdog, the screen and the sensor's health with it.
//
// The pump thread calls the source's next_frame and queues what it gets (the oldest frame is
// dropped and counted when the frame loop falls `max_queued` behind). Exposure requests are handed
// to the pump and applied between two frames, so the source is only ever called from one thread
// while the pump runs.
#pragma once

#include <condition_variable>
#include <cstdint>
#include <deque>
#include <memory>
#include <mutex>
#include <optional>
#include <thread>

#include "appliance/capture/camera_source.hpp"

namespace glint::capture {

class CameraPump final : public CameraSource {
public:
    explicit CameraPump(std::unique_ptr<CameraSource> source, std::size_t max_queued = 4);
    ~CameraPump() override;

    std::string describe() const override { return source_->describe(); }
    void start() override;  // the source's start, then the pump (throws what the source throws)
    void stop() override;   // the pump joined, then the source stopped; idempotent
    std::optional<CameraFrame> next_frame(std::chrono::milliseconds timeout) override;
    void set_exposure(const ExposureRequest& request) override;
    bool finished() const override;
    CameraHealth health() const override;  // the source's, as of its last frame, plus the pump's drops

private:
    void run();

    std::unique_ptr<CameraSource> source_;
    std::size_t max_queued_;
    mutable std::mutex mutex_;
    std::condition_variable ready_;
    std::deque<CameraFrame> queue_;
    std::optional<ExposureRequest> pending_exposure_;
    CameraHealth health_;         // copied from the source by the pump
    std::uint64_t dropped_ = 0;   // frames the frame loop did not take in time
    bool running_ = false, source_finished_ = false;
    std::thread thread_;
};

}  // namespace glint::capture
