#include "appliance/ui/strings.hpp"

#include <algorithm>

#include <toml++/toml.h>

#include "appliance/core/errors.hpp"

namespace glint::ui {
namespace {

// Flattens nested tables into dotted keys; anything but a string is an error naming its line.
void flatten(const toml::table& table, const std::string& prefix, const std::filesystem::path& file,
             std::map<std::string, std::string>& out) {
    for (const auto& [name, node] : table) {
        const std::string key = prefix.empty() ? std::string(name.str()) : prefix + "." + std::string(name.str());
        if (const toml::table* sub = node.as_table()) {
            flatten(*sub, key, file, out);
        } else if (const auto* text = node.as_string()) {
            out[key] = text->get();
        } else {
            throw InputError(file.string() + ":" + std::to_string(node.source().begin.line) + ": key '" + key +
                             "' is not a string");
        }
    }
}

}  // namespace

Strings::Strings(std::map<std::string, std::string> texts, std::filesystem::path file)
    : texts_(texts.begin(), texts.end()), file_(std::move(file)) {}

Strings Strings::load(const std::filesystem::path& file) { return load(file, ui_string_keys()); }

Strings Strings::load(const std::filesystem::path& file, const std::vector<std::string>& required) {
    toml::table table;
    try {
        table = toml::parse_file(file.string());
    } catch (const toml::parse_error& e) {
        // toml++ reports a missing file as a parse error at line 0.
        const auto line = e.source().begin.line;
        throw InputError(file.string() + (line > 0 ? ":" + std::to_string(line) : std::string()) + ": " +
                         std::string(e.description()));
    }
    std::map<std::string, std::string> texts;
    flatten(table, "", file, texts);
    std::string missing;
    for (const std::string& key : required)
        if (!texts.contains(key)) missing += (missing.empty() ? "" : ", ") + key;
    if (!missing.empty()) throw InputError(file.string() + ": missing strings: " + missing);
    return Strings(std::move(texts), file);
}

bool Strings::has(std::string_view key) const { return texts_.find(key) != texts_.end(); }

const std::string& Strings::get(std::string_view key) const {
    if (const auto it = texts_.find(key); it != texts_.end()) return it->second;
    const auto it = missing_.find(key);
    if (it != missing_.end()) return it->second;
    return missing_.emplace(std::string(key), std::string(key)).first->second;
}

std::string Strings::format(std::string_view key, const std::vector<std::pair<std::string, std::string>>& values) const {
    std::string text = get(key);
    for (const auto& [name, value] : values) {
        const std::string place = "{" + name + "}";
        for (std::size_t at = text.find(place); at != std::string::npos; at = text.find(place, at + value.size()))
            text.replace(at, place.size(), value);
    }
    return text;
}

std::vector<std::string> Strings::keys() const {
    std::vector<std::string> out;
    out.reserve(texts_.size());
    for (const auto& [key, text] : texts_) out.push_back(key);
    return out;
}

const std::vector<std::string>& ui_string_keys() {
    // The keys screens.cpp and maintenance_menu.cpp look up, and the ones the kiosk puts into the
    // ScreenModel (steps, materials, messages). tests/ui checks this list against both the code
    // and data/ui/strings.toml.
    static const std::vector<std::string> keys = [] {
        std::vector<std::string> k = {
            "attract.call", "attract.subtitle",
            "capture.title", "capture.turn", "capture.hold", "capture.slower", "capture.progress", "capture.time_left",
            "capture.exposure.ok", "capture.exposure.too_bright", "capture.exposure.too_dark",
            "capture.exposure.bracketing",
            "processing.title", "processing.time_left", "processing.adjusting", "processing.merging",
            "processing.convolving", "processing.loading",
            "ar.hint", "ar.tracking", "ar.tracking_held", "ar.tracking_lost",
            "material.matte", "material.glossy", "material.mirror",
            "message.capture_timeout", "message.capture_failed", "message.processing_timeout", "message.processing_failed",
            "message.camera_problem", "message.sensor_problem",
            "status.sensor_lost", "status.camera_lost", "status.degraded",
            "menu.title", "menu.close", "menu.pages_hint",
            "menu.pin.title", "menu.pin.prompt", "menu.pin.wrong", "menu.pin.locked", "menu.pin.disabled",
            "menu.page.status", "menu.page.calibrations", "menu.page.settings", "menu.page.log", "menu.page.export",
            "menu.page.buttons", "menu.page.pattern", "menu.page.restart",
            "menu.status.sensor", "menu.status.sensor_rate", "menu.status.camera_fps", "menu.status.exposure",
            "menu.status.gain", "menu.status.display", "menu.status.renderer", "menu.status.cpu_temp",
            "menu.status.free_disk", "menu.status.uptime", "menu.status.state", "menu.status.state_store",
            "menu.status.alignment",
            "menu.calib.camera", "menu.calib.response", "menu.calib.vignetting", "menu.calib.alignment",
            "menu.calib.time_offset", "menu.calib.start", "menu.calib.cancel", "menu.calib.step", "menu.calib.result",
            "menu.calib.idle", "menu.calib.apply", "menu.calib.busy",
            "menu.settings.capture", "menu.settings.map_width", "menu.settings.map_height",
            "menu.settings.target_coverage", "menu.settings.max_scan_s", "menu.settings.convolution",
            "menu.settings.tolerance", "menu.settings.apply", "menu.settings.revert",
            "menu.log.empty",
            "menu.export.target", "menu.export.none", "menu.export.start", "menu.export.env_map", "menu.export.maps",
            "menu.export.screenshots", "menu.export.sessions",
            "menu.buttons.button", "menu.buttons.key_switch", "menu.buttons.pressed", "menu.buttons.released",
            "menu.buttons.lamp_on", "menu.buttons.lamp_off", "menu.buttons.lamp_blink",
            "menu.pattern.hint",
            "menu.restart.kiosk", "menu.restart.reboot", "menu.restart.confirm",
        };
        std::sort(k.begin(), k.end());
        return k;
    }();
    return keys;
}

}  // namespace glint::ui
