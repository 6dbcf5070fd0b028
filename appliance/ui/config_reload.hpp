// Reloading the configuration on SIGHUP (docs/service.md, "Reload on SIGHUP"). The file is read
// and validated again; an invalid file changes nothing and its error is reported. Of a valid
// file, the keys that can change live (config_keys.hpp: timeouts, frame budget, capture and
// convolution settings, materials, the PIN) are applied at once; the others (display, camera,
// sensor, GPIO, state directory, the AR model) keep their running values and are reported as
// waiting for a restart.
#pragma once

#include <string>
#include <vector>

#include "appliance/ui/config.hpp"

namespace glint::ui {

struct ReloadReport {
    bool ok = false;
    std::string error;  // !ok: the ConfigError's "FILE:LINE: key '...': ..."
    // Keys ("section.key") whose value in the file differs from the running one, split into
    // those applied now and those that wait for a restart; both in file order.
    std::vector<std::string> applied_keys, restart_keys;
    // Sections with a change, and of those the ones with an applied key and the ones with a
    // key waiting for a restart (a section may be in both: [ar]'s materials are live, its
    // model is not).
    std::vector<std::string> changed_sections, live_sections, restart_sections;

    bool changed() const { return !applied_keys.empty() || !restart_keys.empty(); }
    bool needs_restart() const { return !restart_keys.empty(); }
    // One line for the journal: "config reloaded from F: applied timeouts.ar_idle_s; restart
    // needed for display.kind", "config unchanged", or "config reload failed, keeping the
    // running one: F:3: ...".
    std::string summary() const;
};

// What reloading `loaded` over `running` does: fills the report's key and section lists and
// returns the configuration to run with (running's values with the live keys from `loaded`).
Config merge_reload(const Config& running, const Config& loaded, ReloadReport& report);

// Holds the configuration in effect. Used from one thread (the kiosk's main loop, when its
// signal thread has seen SIGHUP).
class ConfigReloader {
public:
    explicit ConfigReloader(Config initial) : current_(std::move(initial)) {}
    // Reads current().file again. On success current() holds the merged configuration. It
    // reads a file and, when pin_hash is set, checks it with one yescrypt hash (about 20 ms
    // here): one long frame if called on the frame loop.
    ReloadReport reload();
    const Config& current() const { return current_; }

private:
    Config current_;
};

}  // namespace glint::ui
