// The visitor flow as a state machine (docs/kiosk.md, "Visitor flow"), with no I/O: the kiosk
// feeds it what happened (the button, the scan's end, the maps ready, a failure) and the time, and
// acts on the transitions it reports. Times are seconds on the kiosk's clock (the replay's or the
// live one).
//
//   ATTRACT --button--> CAPTURE --scan finished--> PROCESSING --maps ready--> AR --idle--> ATTRACT
//   any state --failure or timeout--> ATTRACT, with a friendly message shown for a while
//   AR --button--> AR (the next material)
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "appliance/ui/config.hpp"
#include "appliance/ui/screen_model.hpp"

namespace glint::ui {

struct Transition {
    KioskState from = KioskState::Attract, to = KioskState::Attract;
    double t_s = 0;
    std::string reason;  // "button", "scan complete", "timeout", the failure's detail, ...
};

class KioskFlow {
public:
    explicit KioskFlow(const TimeoutsSection& timeouts, int materials = 3, double start_s = 0);

    KioskState state() const { return state_; }
    double entered_s() const { return entered_s_; }
    int material() const { return material_; }  // index into the configured materials

    // Each returns the transition it caused, if any. Events that mean nothing in the current state
    // (a scan end outside CAPTURE, a late "maps ready" after a timeout) are ignored.
    std::optional<Transition> button(double t_s);            // ATTRACT: start; AR: next material
    std::optional<Transition> scan_finished(double t_s, const std::string& why);  // CAPTURE -> PROCESSING
    std::optional<Transition> maps_ready(double t_s);        // PROCESSING -> AR
    // Anything that went wrong: back to ATTRACT with `message_key` shown (strings.toml) and
    // `detail` as the transition's reason (for the journal).
    std::optional<Transition> failure(double t_s, const std::string& message_key, const std::string& detail);
    // Timeouts; call every frame.
    std::optional<Transition> tick(double t_s);
    // The scan waits for a device to come back (the orientation sensor replugged, the camera
    // restarted): CAPTURE's timeout stops while it waits, and a wait longer than
    // timeouts.capture_s ends the visit with `message_key` (tick() reports it). Outside CAPTURE a
    // pause means nothing and is ignored; any transition ends it.
    void set_paused(double t_s, bool paused, const std::string& message_key = "message.capture_failed");
    bool paused() const { return paused_since_s_ >= 0; }
    double paused_total_s() const { return paused_total_s_; }

    // The message to show at t_s ("" when none).
    std::string message(double t_s) const;
    void set_timeouts(const TimeoutsSection& timeouts) { timeouts_ = timeouts; }  // SIGHUP
    const std::vector<Transition>& history() const { return history_; }

private:
    Transition go(KioskState to, double t_s, const std::string& reason);

    TimeoutsSection timeouts_;
    int materials_;
    KioskState state_ = KioskState::Attract;
    double entered_s_ = 0, last_input_s_ = 0;
    int material_ = 0;
    std::string message_;
    double message_until_s_ = -1;
    double paused_since_s_ = -1;  // < 0: not paused
    double paused_total_s_ = 0;   // every pause of the run, for the summary
    std::string pause_message_;
    std::vector<Transition> history_;
};

}  // namespace glint::ui
