// sd_notify for Type=notify (service_notify.hpp), through libsystemd.
#include "appliance/ui/service_notify.hpp"

#include <systemd/sd-daemon.h>

#include <cstdlib>
#include <cstring>

namespace glint::ui {

ServiceNotifier::ServiceNotifier() {
    const char* socket = std::getenv("NOTIFY_SOCKET");
    enabled_ = socket && *socket;
}

bool ServiceNotifier::send(const std::string& message) {
    if (!enabled_) return false;
    // unset_environment = 0: the kiosk notifies for its whole life, not once.
    const int r = sd_notify(0, message.c_str());
    if (r > 0) return true;
    last_error_ = r == 0 ? "NOTIFY_SOCKET is no longer set" : std::string("sd_notify: ") + std::strerror(-r);
    return false;
}

std::string status_line(std::string_view text) {
    std::string s(text);
    for (char& c : s)
        if (c == '\n' || c == '\r') c = ' ';
    return s;
}

namespace {
std::string with_status(const char* assignment, std::string_view status) {
    std::string m = assignment;
    if (!status.empty()) m += "\nSTATUS=" + status_line(status);
    return m;
}
}  // namespace

bool ServiceNotifier::ready(std::string_view status) { return send(with_status("READY=1", status)); }
bool ServiceNotifier::status(std::string_view text) { return send("STATUS=" + status_line(text)); }
bool ServiceNotifier::watchdog() { return send("WATCHDOG=1"); }
bool ServiceNotifier::reloading(std::string_view status) { return send(with_status("RELOADING=1", status)); }
bool ServiceNotifier::stopping(std::string_view status) { return send(with_status("STOPPING=1", status)); }

std::optional<std::chrono::microseconds> watchdog_interval() {
    std::uint64_t usec = 0;
    // > 0: enabled for this PID (WATCHDOG_PID unset or ours); 0: off; < 0: malformed variables,
    // which systemd never sets, treated as off.
    if (sd_watchdog_enabled(0, &usec) <= 0 || usec == 0) return std::nullopt;
    return std::chrono::microseconds(static_cast<std::chrono::microseconds::rep>(usec));
}

WatchdogFeeder::WatchdogFeeder(ServiceNotifier& notifier, std::optional<std::chrono::microseconds> interval)
    : notifier_(notifier),
      period_ns_(interval ? std::chrono::duration_cast<std::chrono::nanoseconds>(*interval).count() / 2 : 0) {}

bool WatchdogFeeder::tick(std::int64_t now_ns) {
    if (period_ns_ <= 0) return false;
    if (pinged_ && now_ns - last_ns_ < period_ns_) return false;
    pinged_ = true;
    last_ns_ = now_ns;
    return notifier_.watchdog();
}

}  // namespace glint::ui
