#include "appliance/ui/kiosk_flow.hpp"

#include <algorithm>

namespace glint::ui {

const char* kiosk_state_name(KioskState state) {
    switch (state) {
        case KioskState::Attract: return "ATTRACT";
        case KioskState::Capture: return "CAPTURE";
        case KioskState::Processing: return "PROCESSING";
        case KioskState::Ar: return "AR";
    }
    return "?";
}

KioskFlow::KioskFlow(const TimeoutsSection& timeouts, int materials, double start_s)
    : timeouts_(timeouts), materials_(std::max(1, materials)), entered_s_(start_s), last_input_s_(start_s) {}

Transition KioskFlow::go(KioskState to, double t_s, const std::string& reason) {
    Transition t{state_, to, t_s, reason};
    if (paused()) paused_total_s_ += t_s - paused_since_s_;
    paused_since_s_ = -1;
    state_ = to;
    entered_s_ = t_s;
    last_input_s_ = t_s;
    history_.push_back(t);
    return t;
}

std::optional<Transition> KioskFlow::button(double t_s) {
    last_input_s_ = t_s;
    switch (state_) {
        case KioskState::Attract:
            message_.clear();  // a new visitor: the last one's apology is gone
            return go(KioskState::Capture, t_s, "button");
        case KioskState::Ar:
            material_ = (material_ + 1) % materials_;
            return std::nullopt;
        default:
            return std::nullopt;  // a press during the scan or the processing changes nothing
    }
}

std::optional<Transition> KioskFlow::scan_finished(double t_s, const std::string& why) {
    if (state_ != KioskState::Capture) return std::nullopt;
    return go(KioskState::Processing, t_s, why);
}

std::optional<Transition> KioskFlow::maps_ready(double t_s) {
    if (state_ != KioskState::Processing) return std::nullopt;
    material_ = 0;  // every visitor starts on the first material
    return go(KioskState::Ar, t_s, "maps ready");
}

std::optional<Transition> KioskFlow::failure(double t_s, const std::string& message_key, const std::string& detail) {
    message_ = message_key;
    message_until_s_ = t_s + timeouts_.message_s;
    return go(KioskState::Attract, t_s, detail);
}

std::optional<Transition> KioskFlow::tick(double t_s) {
    const double in_state = t_s - entered_s_;
    switch (state_) {
        case KioskState::Attract:
            // A periodic restart of the attract loop (0: none): the last scene reloaded.
            if (timeouts_.attract_s > 0 && in_state > timeouts_.attract_s) return go(KioskState::Attract, t_s, "timeout");
            return std::nullopt;
        case KioskState::Capture:
            if (paused()) {
                if (timeouts_.capture_s > 0 && t_s - paused_since_s_ > timeouts_.capture_s)
                    return failure(t_s, pause_message_, "timeout: the scan waited longer than timeouts.capture_s for a device");
                return std::nullopt;
            }
            if (timeouts_.capture_s > 0 && in_state > timeouts_.capture_s)
                return failure(t_s, "message.capture_timeout", "timeout: the scan took longer than timeouts.capture_s");
            return std::nullopt;
        case KioskState::Processing:
            if (timeouts_.processing_s > 0 && in_state > timeouts_.processing_s)
                return failure(t_s, "message.processing_timeout", "timeout: processing took longer than timeouts.processing_s");
            return std::nullopt;
        case KioskState::Ar:
            if (timeouts_.ar_idle_s > 0 && t_s - last_input_s_ > timeouts_.ar_idle_s) return go(KioskState::Attract, t_s, "idle");
            return std::nullopt;
    }
    return std::nullopt;
}

void KioskFlow::set_paused(double t_s, bool paused_now, const std::string& message_key) {
    if (state_ != KioskState::Capture || paused_now == paused()) return;
    if (paused_now) {
        paused_since_s_ = t_s;
        pause_message_ = message_key;
    } else {
        // The wait does not count against the scan: CAPTURE is entered again that much later.
        const double waited = t_s - paused_since_s_;
        entered_s_ += waited;
        paused_total_s_ += waited;
        paused_since_s_ = -1;
    }
}

std::string KioskFlow::message(double t_s) const { return t_s < message_until_s_ ? message_ : std::string(); }

}  // namespace glint::ui
