#include "appliance/capture/replay_camera.hpp"

#include "appliance/core/errors.hpp"

namespace glint::capture {

ReplayCamera::ReplayCamera(Session session, host::Clock& clock) : session_(std::move(session)), clock_(clock) {}

std::string ReplayCamera::describe() const {
    const Intrinsics& k = session_.calibration.intrinsics;
    return "replay: " + session_.dir.string() + " (" + std::to_string(session_.frames.size()) + " frames, " +
           std::to_string(k.width) + "x" + std::to_string(k.height) + ")";
}

void ReplayCamera::start() {
    running_ = true;
    next_ = 0;
    start_us_ = clock_.now_us();
}

std::optional<CameraFrame> ReplayCamera::next_frame(std::chrono::milliseconds timeout) {
    if (!running_ || finished()) return std::nullopt;
    const FrameRecord& r = session_.frames[next_];
    const std::int64_t since_first_ns = r.t_ns - session_.frames.front().t_ns;
    if (!wait_until_due(clock_, start_us_ + std::uint64_t(since_first_ns / 1000), timeout)) {
        ++health_.timeouts;
        return std::nullopt;
    }
    try {
        CameraFrame f = load_frame(session_, r);
        check_frame_size(session_, r, f);
        ++next_;
        ++health_.frames;
        if (next_ >= 2 && r.index != session_.frames[next_ - 2].index + 1) health_.dropped += r.index - session_.frames[next_ - 2].index - 1;
        return f;
    } catch (const InputError& e) {
        // A damaged or missing frame file: reported, skipped, the replay goes on.
        ++next_;
        health_.last_error = e.what();
        ++health_.dropped;
        return std::nullopt;
    }
}

}  // namespace glint::capture
