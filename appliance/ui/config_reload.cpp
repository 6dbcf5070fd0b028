// SIGHUP reload: what changed, what is applied now, what waits for a restart (config_reload.hpp).
#include "appliance/ui/config_reload.hpp"

#include <algorithm>

#include "appliance/ui/config_keys.hpp"

namespace glint::ui {
namespace {

void add_once(std::vector<std::string>& list, const std::string& item) {
    if (std::find(list.begin(), list.end(), item) == list.end()) list.push_back(item);
}

std::string join(const std::vector<std::string>& items) {
    std::string out;
    for (std::size_t k = 0; k < items.size(); ++k) out += (k ? ", " : "") + items[k];
    return out;
}

}  // namespace

Config merge_reload(const Config& running, const Config& loaded, ReloadReport& report) {
    report.ok = true;
    Config merged = running;
    merged.file = loaded.file;
    for (const std::string& name : changed_keys(running, loaded)) {
        const auto& keys = config_keys();
        const auto it = std::find_if(keys.begin(), keys.end(), [&](const ConfigKeyInfo& k) { return k.name() == name; });
        add_once(report.changed_sections, it->section);
        if (it->live) {
            copy_key(merged, loaded, name);
            report.applied_keys.push_back(name);
            add_once(report.live_sections, it->section);
        } else {
            report.restart_keys.push_back(name);
            add_once(report.restart_sections, it->section);
        }
    }
    return merged;
}

std::string ReloadReport::summary() const {
    if (!ok) return "config reload failed, keeping the running configuration: " + error;
    if (!changed()) return "config reloaded, nothing changed";
    std::string s = "config reloaded";
    if (!applied_keys.empty()) s += ": applied " + join(applied_keys);
    if (!restart_keys.empty()) s += std::string(applied_keys.empty() ? ":" : ";") + " restart needed for " + join(restart_keys);
    return s;
}

ReloadReport ConfigReloader::reload() {
    ReloadReport report;
    Config loaded;
    try {
        loaded = load_config(current_.file);
    } catch (const ConfigError& e) {
        report.ok = false;
        report.error = e.what();
        return report;
    }
    current_ = merge_reload(current_, loaded, report);
    return report;
}

}  // namespace glint::ui
