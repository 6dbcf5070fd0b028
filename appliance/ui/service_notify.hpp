// The kiosk's side of systemd's Type=notify protocol (sd_notify(3), docs/service.md): READY=1
// once the first frame is on screen, STATUS= with the state, WATCHDOG=1 from the frame loop at
// half the unit's WatchdogSec=, RELOADING=1 around a SIGHUP reload, STOPPING=1 on SIGTERM. When
// NOTIFY_SOCKET is unset (run by hand, tests, replay) every call does nothing.
#pragma once

#include <chrono>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>

namespace glint::ui {

// sd_notify itself may be called from any thread (each call sends one datagram); last_error()
// is the one piece of state, so give each thread that notifies its own ServiceNotifier.
class ServiceNotifier {
public:
    // Reads NOTIFY_SOCKET once; the environment is left as it is (children started later,
    // such as glint-vision by execv, are not the main process and must not notify anyway:
    // the unit has NotifyAccess=main).
    ServiceNotifier();

    bool enabled() const { return enabled_; }

    // Each returns true when the message was sent, false when disabled or when sending failed
    // (last_error() says why). They never throw: the frame loop calls them.
    bool ready(std::string_view status = {});
    bool status(std::string_view text);
    bool watchdog();
    bool reloading(std::string_view status = {});
    bool stopping(std::string_view status = {});
    // Any assignments, one per line ("KEY=VALUE\n...").
    bool send(const std::string& message);

    const std::string& last_error() const { return last_error_; }

private:
    bool enabled_ = false;
    std::string last_error_;
};

// STATUS= text with what would end the assignment (a newline) replaced by a space: a state name
// or an error message cannot smuggle in a READY=1 or a MAINPID=.
std::string status_line(std::string_view text);

// The unit's watchdog interval (WatchdogSec=, from WATCHDOG_USEC when WATCHDOG_PID is this
// process), or nullopt when the watchdog is off for this process.
std::optional<std::chrono::microseconds> watchdog_interval();

// Sends WATCHDOG=1 at most every half interval, from a loop that calls tick() every frame: half,
// as sd_watchdog_enabled(3) advises, so one late frame does not miss the deadline.
class WatchdogFeeder {
public:
    WatchdogFeeder(ServiceNotifier& notifier, std::optional<std::chrono::microseconds> interval);
    // Pings when at least half the interval has passed since the last ping (the first call
    // always pings). Returns whether it pinged.
    bool tick(std::int64_t now_ns);
    std::int64_t period_ns() const { return period_ns_; }  // 0 = no watchdog

private:
    ServiceNotifier& notifier_;
    std::int64_t period_ns_ = 0;
    std::int64_t last_ns_ = 0;
    bool pinged_ = false;
};

}  // namespace glint::ui
