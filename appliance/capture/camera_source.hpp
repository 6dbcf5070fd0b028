// CameraSource: the one interface through which the capture pipeline (and later the kiosk) gets
// camera frames. Backends: libcamera (the real camera), replay (a recorded session's frames on a
// clock) and the simulator (appliance/sim: frames rendered on demand from an HDR map along a
// trajectory); camera_factory.hpp makes one from a spec. A frame carries its appliance-monotonic
// timestamp, exposure time and gains (camera_frame.hpp).
#pragma once

#include <chrono>
#include <cstdint>
#include <optional>
#include <stdexcept>
#include <string>

#include "appliance/capture/camera_frame.hpp"
#include "firmware_bridge/host/clock.hpp"

namespace glint::capture {

// A camera cannot be opened or configured at all. The message says what was found instead.
class CameraError : public std::runtime_error {
    using std::runtime_error::runtime_error;
};

// What the source is asked to do with exposure.
struct ExposureRequest {
    bool automatic = true;
    double exposure_s = 0.01;  // manual only
    double analogue_gain = 1;  // manual only
};

struct CameraHealth {
    std::uint64_t frames = 0;     // delivered
    std::uint64_t dropped = 0;    // sequence gaps seen by the source
    std::uint64_t timeouts = 0;   // waits that ended without a frame
    std::uint64_t restarts = 0;   // the camera was stopped and started again to recover
    std::string last_error;       // "" when none
};

class CameraSource {
public:
    virtual ~CameraSource() = default;
    virtual std::string describe() const = 0;  // "libcamera: imx708 1280x720 RGB888", "replay: DIR"
    virtual void start() = 0;                  // throws CameraError when it cannot
    virtual void stop() = 0;                   // idempotent
    // The next frame, waiting up to `timeout`; nullopt when none came (see health()) or a finite
    // source has ended (finished()).
    virtual std::optional<CameraFrame> next_frame(std::chrono::milliseconds timeout) = 0;
    // Applies from the next frame the source can still change (a few frames later on real cameras).
    virtual void set_exposure(const ExposureRequest& request) = 0;
    virtual bool finished() const { return false; }
    virtual CameraHealth health() const = 0;
};

// For a source that delivers each frame when `clock` reaches the frame's due time (replay,
// simulator): waits until `due_us` when that falls within `timeout`, else waits out the timeout
// and returns false.
inline bool wait_until_due(host::Clock& clock, std::uint64_t due_us, std::chrono::milliseconds timeout) {
    const std::uint64_t deadline = clock.now_us() + std::uint64_t(timeout.count()) * 1000;
    if (due_us > deadline) {
        clock.sleep_until_us(deadline);
        return false;
    }
    clock.sleep_until_us(due_us);
    return true;
}

}  // namespace glint::capture
