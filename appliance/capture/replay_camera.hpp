// Replay of a recorded session's frames as a camera: each frame is delivered when the clock
// (host/clock.hpp) reaches its recorded time (relative to the first frame), so a SteadyClock
// plays at recorded speed and a VirtualClock as fast as the reader takes them, deterministically,
// on the same virtual timeline as the session's sensor recording. Exposure requests are recorded
// facts of the session and cannot be changed: set_exposure is ignored.
#pragma once

#include <memory>

#include "appliance/capture/camera_source.hpp"
#include "appliance/capture/session.hpp"

namespace glint::capture {

class ReplayCamera final : public CameraSource {
public:
    // `clock` paces the frames (microseconds); a frame recorded at t_ns is due at
    // start + (t_ns - first t_ns). Frame times keep their recorded values.
    ReplayCamera(Session session, host::Clock& clock);
    std::string describe() const override;
    void start() override;
    void stop() override { running_ = false; }
    std::optional<CameraFrame> next_frame(std::chrono::milliseconds timeout) override;
    void set_exposure(const ExposureRequest&) override {}
    bool finished() const override { return next_ >= session_.frames.size(); }
    CameraHealth health() const override { return health_; }

private:
    Session session_;
    host::Clock& clock_;
    std::uint64_t start_us_ = 0;
    std::size_t next_ = 0;
    bool running_ = false;
    CameraHealth health_;
};

}  // namespace glint::capture
