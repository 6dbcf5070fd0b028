// The appliance's TOML configuration (config.hpp): one table of keys drives parsing, validation,
// comparison (SIGHUP reload) and writing, so a field added to Config needs one line here; the
// tests in tests/service/test_config.cpp fail until it has one and the example shows it.
#include "appliance/ui/config.hpp"

#include <algorithm>
#include <cerrno>
#include <charconv>
#include <cctype>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <functional>
#include <limits>
#include <map>
#include <optional>
#include <set>
#include <sstream>
#include <stdexcept>
#include <string_view>
#include <type_traits>

#include <toml++/toml.h>

#include "appliance/core/errors.hpp"
#include "appliance/render/material.hpp"
#include "appliance/render/mesh.hpp"
#include "appliance/ui/config_keys.hpp"
#include "appliance/ui/pin_lock.hpp"

namespace glint::ui {
namespace {

// A value the key cannot take; the caller prefixes "FILE:LINE: key 'section.key': ".
struct Reason {
    std::string text;
};

using Check = std::optional<std::string>;  // nullopt = fine, else why not

std::string type_name(const toml::node& node) {
    switch (node.type()) {
        case toml::node_type::string: return "a string";
        case toml::node_type::integer: return "an integer";
        case toml::node_type::floating_point: return "a floating-point number";
        case toml::node_type::boolean: return "a boolean";
        case toml::node_type::array: return "an array";
        case toml::node_type::table: return "a table";
        case toml::node_type::date: return "a date";
        case toml::node_type::time: return "a time";
        case toml::node_type::date_time: return "a date-time";
        case toml::node_type::none: break;
    }
    return "nothing";
}

[[noreturn]] void wrong_type(const toml::node& node, const char* wanted) {
    throw Reason{std::string("wrong type: ") + wanted + " is needed, not " + type_name(node)};
}

// Conversions from a TOML node to a field's C++ type. A double key takes an integer as well
// ("budget_ms = 40" means 40.0); an int key takes no float (a line number of 17.5 is a typo).
template <class T>
T convert(const toml::node& node);

template <>
std::string convert<std::string>(const toml::node& node) {
    if (const auto* s = node.as_string()) return s->get();
    wrong_type(node, "a string");
}

template <>
int convert<int>(const toml::node& node) {
    const auto* i = node.as_integer();
    if (!i) wrong_type(node, "an integer");
    const std::int64_t v = i->get();
    if (v < std::numeric_limits<int>::min() || v > std::numeric_limits<int>::max())
        throw Reason{std::to_string(v) + " does not fit an int"};
    return static_cast<int>(v);
}

template <>
double convert<double>(const toml::node& node) {
    double v = 0;
    if (const auto* f = node.as_floating_point())
        v = f->get();
    else if (const auto* i = node.as_integer())
        v = static_cast<double>(i->get());
    else
        wrong_type(node, "a number");
    // TOML allows inf and nan; no key of ours means either.
    if (!std::isfinite(v)) throw Reason{"must be a finite number"};
    return v;
}

template <>
bool convert<bool>(const toml::node& node) {
    if (const auto* b = node.as_boolean()) return b->get();
    wrong_type(node, "a boolean (true or false)");
}

template <>
std::vector<std::string> convert<std::vector<std::string>>(const toml::node& node) {
    const auto* array = node.as_array();
    if (!array) wrong_type(node, "an array of strings");
    std::vector<std::string> out;
    for (std::size_t k = 0; k < array->size(); ++k) {
        const auto* s = (*array)[k].as_string();
        if (!s) throw Reason{"element " + std::to_string(k + 1) + " is " + type_name((*array)[k]) + ", not a string"};
        out.push_back(s->get());
    }
    return out;
}

// --- TOML literals (to_toml, format_value) ------------------------------------------------------

std::string literal(const std::string& s) {
    std::string out = "\"";
    for (const char c : s) {
        const auto u = static_cast<unsigned char>(c);
        if (c == '"') out += "\\\"";
        else if (c == '\\') out += "\\\\";
        else if (c == '\n') out += "\\n";
        else if (c == '\t') out += "\\t";
        else if (u < 0x20 || u == 0x7f) {
            char buf[8];
            std::snprintf(buf, sizeof buf, "\\u%04x", u);
            out += buf;
        } else out += c;
    }
    return out + "\"";
}
std::string literal(int v) { return std::to_string(v); }
std::string literal(bool v) { return v ? "true" : "false"; }
std::string literal(double v) {
    // Shortest text that reads back to the same double; ".0" keeps it a TOML float.
    char buf[64];
    const auto end = std::to_chars(buf, buf + sizeof buf, v).ptr;
    std::string s(buf, end);
    if (s.find_first_of(".e") == std::string::npos) s += ".0";
    return s;
}
std::string literal(const std::vector<std::string>& v) {
    std::string out = "[";
    for (std::size_t k = 0; k < v.size(); ++k) out += (k ? ", " : "") + literal(v[k]);
    return out + "]";
}

// --- checks ----------------------------------------------------------------------------------

std::string join(const std::vector<std::string>& items, const char* sep = ", ") {
    std::string out;
    for (std::size_t k = 0; k < items.size(); ++k) out += (k ? sep : "") + items[k];
    return out;
}

std::function<Check(const std::string&)> one_of(std::vector<std::string> allowed) {
    return [allowed](const std::string& v) -> Check {
        if (std::find(allowed.begin(), allowed.end(), v) != allowed.end()) return std::nullopt;
        return "'" + v + "' is not one of " + join(allowed);
    };
}

std::function<Check(const int&)> int_range(int lo, int hi) {
    return [lo, hi](const int& v) -> Check {
        if (v >= lo && v <= hi) return std::nullopt;
        return std::to_string(v) + " is out of range [" + std::to_string(lo) + ", " + std::to_string(hi) + "]";
    };
}

// (lo, hi] when lo_open, else [lo, hi].
std::function<Check(const double&)> real_range(double lo, double hi, bool lo_open) {
    return [=](const double& v) -> Check {
        if ((lo_open ? v > lo : v >= lo) && v <= hi) return std::nullopt;
        return literal(v) + " is out of range " + (lo_open ? "(" : "[") + literal(lo) + ", " + literal(hi) + "]";
    };
}

Check absolute_path(const std::string& v) {
    if (v.empty() || v.front() != '/') return "'" + v + "' is not an absolute path";
    return std::nullopt;
}

// "KIND[:ARGUMENT]" with KIND from `kinds`. The kinds are those of the factories that make the
// sources (capture/camera_factory.hpp with sim's simulator; firmware_bridge/host/source_spec.hpp);
// ui may not include the host headers (tests/arch), so the arguments are checked when the kiosk
// makes the source, and tests/service/test_config.cpp checks these lists against the factories.
std::function<Check(const std::string&)> source_spec(std::vector<std::string> kinds, bool argument_required) {
    return [=](const std::string& v) -> Check {
        const auto colon = v.find(':');
        const std::string kind = v.substr(0, colon);
        if (std::find(kinds.begin(), kinds.end(), kind) == kinds.end())
            return "'" + v + "': unknown kind '" + kind + "' (want " + join(kinds) + ")";
        if (argument_required && (colon == std::string::npos || colon + 1 == v.size()))
            return "'" + v + "': '" + kind + ":' needs what follows the colon";
        return std::nullopt;
    };
}

// "auto", "none" or a VT's device, /dev/tty1 .. /dev/tty63 (gl/vt_lock.hpp; the node itself is
// checked when the display opens it).
Check vt_spec(const std::string& v) {
    if (v == "auto" || v == "none") return std::nullopt;
    const std::string_view prefix = "/dev/tty";
    const std::string_view n = std::string_view(v).substr(std::min(v.size(), prefix.size()));
    if (v.rfind(prefix, 0) == 0 && !n.empty() && n.size() <= 2 && n[0] != '0' &&
        std::all_of(n.begin(), n.end(), [](char c) { return c >= '0' && c <= '9'; }) && std::stoi(std::string(n)) <= 63)
        return std::nullopt;
    return "'" + v + "' is not auto, none or a VT /dev/tty1 .. /dev/tty63";
}

// "" or "WIDTHxHEIGHT" or "WIDTHxHEIGHT@HZ" (gl/kms_output.hpp's KmsRequest::mode).
Check kms_mode(const std::string& v) {
    if (v.empty()) return std::nullopt;
    const auto bad = [&] { return Check("'" + v + "' is not WIDTHxHEIGHT or WIDTHxHEIGHT@HZ"); };
    const auto x = v.find('x');
    const auto at = v.find('@');
    if (x == std::string::npos) return bad();
    const auto digits = [](std::string_view s) {
        return !s.empty() && std::all_of(s.begin(), s.end(), [](char c) { return c >= '0' && c <= '9'; });
    };
    const std::string_view sv(v);
    if (!digits(sv.substr(0, x))) return bad();
    if (!digits(sv.substr(x + 1, at == std::string::npos ? std::string_view::npos : at - x - 1))) return bad();
    if (at != std::string::npos) {
        const std::string_view hz = sv.substr(at + 1);
        double value = 0;
        const auto [end, ec] = std::from_chars(hz.data(), hz.data() + hz.size(), value);
        if (hz.empty() || ec != std::errc() || end != hz.data() + hz.size() || !(value > 0)) return bad();
    }
    return std::nullopt;
}

// "" (no chord: the key switch only) or modifiers and one key joined by '+', e.g. "ctrl+alt+m".
// At least one modifier: a single key on a keyboard plugged in by a visitor must not reach the
// PIN prompt.
Check chord(const std::string& v) {
    if (v.empty()) return std::nullopt;
    static const std::set<std::string> modifiers = {"ctrl", "alt", "shift", "super"};
    std::vector<std::string> parts;
    std::size_t k = 0;
    while (true) {
        const auto plus = v.find('+', k);
        parts.push_back(v.substr(k, plus == std::string::npos ? std::string::npos : plus - k));
        if (plus == std::string::npos) break;
        k = plus + 1;
    }
    const auto bad = [&](const std::string& why) { return Check("'" + v + "': " + why); };
    if (parts.size() < 2) return bad("needs at least one modifier (ctrl, alt, shift, super) and a key");
    std::set<std::string> seen;
    for (std::size_t p = 0; p + 1 < parts.size(); ++p) {
        if (!modifiers.count(parts[p])) return bad("'" + parts[p] + "' is not a modifier (ctrl, alt, shift, super)");
        if (!seen.insert(parts[p]).second) return bad("'" + parts[p] + "' given twice");
    }
    const std::string& key = parts.back();
    const bool letter_or_digit = key.size() == 1 && ((key[0] >= 'a' && key[0] <= 'z') || (key[0] >= '0' && key[0] <= '9'));
    bool function_key = false;
    if (key.size() >= 2 && key.size() <= 3 && key[0] == 'f') {
        int n = 0;
        const auto [end, ec] = std::from_chars(key.data() + 1, key.data() + key.size(), n);
        function_key = ec == std::errc() && end == key.data() + key.size() && n >= 1 && n <= 12;
    }
    if (!letter_or_digit && !function_key) return bad("the key '" + key + "' is not a-z, 0-9 or f1-f12");
    return std::nullopt;
}

Check pin_hash(const std::string& v) {
    if (v.empty()) return std::nullopt;
    if (auto problem = pin_hash_problem(v)) return *problem;
    return std::nullopt;
}

Check materials(const std::vector<std::string>& v) {
    if (v.empty()) return "needs at least one material";
    std::set<std::string> seen;
    for (const auto& m : v) {
        if (!seen.insert(m).second) return "'" + m + "' is listed twice";
        // The renderer's own parser: what it accepts here, the kiosk can shade.
        try {
            render::parse_material(m, "material");
        } catch (const InputError& e) {
            return std::string(e.what());
        }
    }
    return std::nullopt;
}

// What render::load_model accepts, checked without building the mesh (a teapot:400 is ten
// million triangles): sphere, teapot, teapot:LEVEL (1-400), or an existing .obj, .gltf or .glb
// file. tests/service/test_config.cpp holds this to load_model.
Check model(const std::string& v) {
    if (!render::model_is_file(v)) {
        if (v == "sphere" || v == "teapot") return std::nullopt;
        const std::string_view level_text = std::string_view(v).substr(7);
        int level = 0;
        const auto [end, ec] = std::from_chars(level_text.data(), level_text.data() + level_text.size(), level);
        if (level_text.empty() || ec != std::errc() || end != level_text.data() + level_text.size() || level < 1 || level > 400)
            return "'" + v + "': the teapot's level must be an integer in [1, 400]";
        return std::nullopt;
    }
    std::string ext = std::filesystem::path(v).extension().string();
    std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return char(std::tolower(c)); });
    if (ext != ".obj" && ext != ".gltf" && ext != ".glb")
        return "'" + v + "' is neither sphere, teapot, teapot:LEVEL nor an .obj, .gltf or .glb file";
    std::error_code ec;
    if (!std::filesystem::is_regular_file(v, ec)) return "'" + v + "': no such file";
    return std::nullopt;
}

// --- the table of keys ------------------------------------------------------------------------

struct Key {
    ConfigKeyInfo info;
    std::function<void(Config&, const toml::node&)> read;  // throws Reason
    std::function<bool(const Config&, const Config&)> same;
    std::function<void(Config&, const Config&)> copy;
    std::function<std::string(const Config&)> format;
    std::function<Check(const Config&)> check;  // the range check alone (defaults are checked too)
};

template <class S, class T>
Key key(const char* section, S Config::*sec, const char* name, T S::*member, bool live,
        std::type_identity_t<std::function<Check(const T&)>> check = {}) {
    Key k;
    k.info = {section, name, live};
    k.check = [=](const Config& c) -> Check { return check ? check(c.*sec.*member) : std::nullopt; };
    k.read = [=](Config& c, const toml::node& node) {
        T value = convert<T>(node);
        if (check)
            if (auto why = check(value)) throw Reason{*why};
        c.*sec.*member = std::move(value);
    };
    k.same = [=](const Config& a, const Config& b) { return a.*sec.*member == b.*sec.*member; };
    k.copy = [=](Config& to, const Config& from) { to.*sec.*member = from.*sec.*member; };
    k.format = [=](const Config& c) { return literal(c.*sec.*member); };
    return k;
}

// Liveness, per key (docs/service.md, "Reload on SIGHUP"): what the frame loop or a state reads
// afresh may change live; what opened a device, loaded a model or placed files needs a restart.
constexpr bool kLive = true, kRestart = false;

const std::vector<Key>& keys() {
    static const std::vector<Key> table = [] {
        using C = Config;
        std::vector<Key> t;
        // [display]: the display is opened once, with the GL context everything else uses.
        t.push_back(key("display", &C::display, "kind", &DisplaySection::kind, kRestart,
                        one_of({"auto", "kms", "window", "headless"})));
        t.push_back(key("display", &C::display, "card", &DisplaySection::card, kRestart,
                        std::function<Check(const std::string&)>([](const std::string& v) -> Check {
                            return v.empty() ? std::nullopt : absolute_path(v);
                        })));
        t.push_back(key("display", &C::display, "connector", &DisplaySection::connector, kRestart));
        t.push_back(key("display", &C::display, "mode", &DisplaySection::mode, kRestart,
                        std::function<Check(const std::string&)>(kms_mode)));
        t.push_back(key("display", &C::display, "kms_api", &DisplaySection::kms_api, kRestart,
                        one_of({"auto", "atomic", "legacy"})));
        t.push_back(key("display", &C::display, "width", &DisplaySection::width, kRestart, int_range(16, 16384)));
        t.push_back(key("display", &C::display, "height", &DisplaySection::height, kRestart, int_range(16, 16384)));
        t.push_back(key("display", &C::display, "fullscreen", &DisplaySection::fullscreen, kRestart));
        // The lock-down of the KMS display (docs/lockdown.md), taken when the display opens.
        t.push_back(key("display", &C::display, "vt", &DisplaySection::vt, kRestart,
                        std::function<Check(const std::string&)>(vt_spec)));
        t.push_back(key("display", &C::display, "vt_lock_switch", &DisplaySection::vt_lock_switch, kRestart));
        t.push_back(key("display", &C::display, "vt_switch", &DisplaySection::vt_switch, kRestart,
                        one_of({"refuse", "release"})));
        t.push_back(key("display", &C::display, "keyboard", &DisplaySection::keyboard, kRestart,
                        one_of({"grab", "shared", "none"})));
        // [camera], [sensor], [gpio]: devices opened at start.
        t.push_back(key("camera", &C::camera, "source", &CameraSection::source, kRestart,
                        source_spec({"libcamera", "replay", "simulator"}, false)));
        t.push_back(key("camera", &C::camera, "calibration", &CameraSection::calibration, kRestart));
        t.push_back(key("sensor", &C::sensor, "source", &SensorSection::source, kRestart,
                        source_spec({"serial", "i2c", "modbus-tcp", "modbus-rtu", "replay"}, true)));
        // Linux's GPIO character devices number lines within a chip from 0; 1023 is far beyond
        // any SBC header and catches a pin number typed with an extra digit.
        t.push_back(key("gpio", &C::gpio, "chip", &GpioSection::chip, kRestart));
        t.push_back(key("gpio", &C::gpio, "button_line", &GpioSection::button_line, kRestart, int_range(0, 1023)));
        t.push_back(key("gpio", &C::gpio, "key_switch_line", &GpioSection::key_switch_line, kRestart, int_range(-1, 1023)));
        t.push_back(key("gpio", &C::gpio, "lamp_line", &GpioSection::lamp_line, kRestart, int_range(-1, 1023)));
        t.push_back(key("gpio", &C::gpio, "debounce_ms", &GpioSection::debounce_ms, kRestart, real_range(0, 1000, false)));
        // [frame]: read by the frame scheduler every frame.
        t.push_back(key("frame", &C::frame, "budget_ms", &FrameSection::budget_ms, kLive, real_range(0, 1000, true)));
        t.push_back(key("frame", &C::frame, "hard_cap_ms", &FrameSection::hard_cap_ms, kLive, real_range(0, 10000, true)));
        t.push_back(key("frame", &C::frame, "watchdog_s", &FrameSection::watchdog_s, kLive, real_range(0, 3600, true)));
        // [capture]: read when a scan starts.
        t.push_back(key("capture", &C::capture, "map_width", &CaptureSection::map_width, kLive, int_range(16, 8192)));
        t.push_back(key("capture", &C::capture, "map_height", &CaptureSection::map_height, kLive, int_range(8, 4096)));
        t.push_back(key("capture", &C::capture, "target_coverage", &CaptureSection::target_coverage, kLive,
                        real_range(0, 1, true)));
        t.push_back(key("capture", &C::capture, "max_scan_s", &CaptureSection::max_scan_s, kLive, real_range(0, 3600, true)));
        // [convolution]: read when PROCESSING plans the maps.
        t.push_back(key("convolution", &C::convolution, "tolerance", &ConvolutionSection::tolerance, kLive,
                        real_range(0, 1, true)));
        // [ar]: the model, its size and the board are loaded or measured once; the materials too
        // (their lobes are the maps PROCESSING makes; the kiosk does not rebuild them on SIGHUP).
        t.push_back(key("ar", &C::ar, "model", &ArSection::model, kRestart, std::function<Check(const std::string&)>(model)));
        t.push_back(key("ar", &C::ar, "object_radius_m", &ArSection::object_radius_m, kRestart, real_range(0, 10, true)));
        t.push_back(key("ar", &C::ar, "board_width_mm", &ArSection::board_width_mm, kRestart, real_range(0, 10000, false)));
        t.push_back(key("ar", &C::ar, "materials", &ArSection::materials, kRestart,
                        std::function<Check(const std::vector<std::string>&)>(materials)));
        t.push_back(key("ar", &C::ar, "shadows", &ArSection::shadows, kRestart));
        t.push_back(key("ar", &C::ar, "match_camera", &ArSection::match_camera, kRestart));
        // [timeouts]: read each time a state is entered. A day is more than any exhibit state.
        t.push_back(key("timeouts", &C::timeouts, "attract_s", &TimeoutsSection::attract_s, kLive, real_range(0, 86400, false)));
        t.push_back(key("timeouts", &C::timeouts, "capture_s", &TimeoutsSection::capture_s, kLive, real_range(0, 86400, true)));
        t.push_back(key("timeouts", &C::timeouts, "processing_s", &TimeoutsSection::processing_s, kLive, real_range(0, 86400, true)));
        t.push_back(key("timeouts", &C::timeouts, "ar_idle_s", &TimeoutsSection::ar_idle_s, kLive, real_range(0, 86400, true)));
        t.push_back(key("timeouts", &C::timeouts, "message_s", &TimeoutsSection::message_s, kLive, real_range(0, 86400, true)));
        // [maintenance]: read when the menu's overlay starts (the kiosk does not pass a reload on
        // to PinLock::set_policy yet): a new PIN needs a restart.
        t.push_back(key("maintenance", &C::maintenance, "pin_hash", &MaintenanceSection::pin_hash, kRestart,
                        std::function<Check(const std::string&)>(pin_hash)));
        t.push_back(key("maintenance", &C::maintenance, "max_attempts", &MaintenanceSection::max_attempts, kRestart, int_range(1, 100)));
        t.push_back(key("maintenance", &C::maintenance, "lockout_s", &MaintenanceSection::lockout_s, kRestart, real_range(0, 86400, true)));
        t.push_back(key("maintenance", &C::maintenance, "chord", &MaintenanceSection::chord, kRestart,
                        std::function<Check(const std::string&)>(chord)));
        // [state]: files are placed there from the start; the unit's StateDirectory= makes it.
        t.push_back(key("state", &C::state, "dir", &StateSection::dir, kRestart, std::function<Check(const std::string&)>(absolute_path)));
        t.push_back(key("state", &C::state, "export_dir", &StateSection::export_dir, kRestart,
                        std::function<Check(const std::string&)>(absolute_path)));
        return t;
    }();
    return table;
}

const Key* find_key(const std::string& name) {
    for (const auto& k : keys())
        if (k.info.name() == name) return &k;
    return nullptr;
}

// --- validation across keys ---------------------------------------------------------------------

struct Problem {
    std::string key;  // the key the message names (its line is used when the file has it)
    std::string why;
};

std::optional<Problem> cross_check(const Config& c) {
    if (c.frame.hard_cap_ms < c.frame.budget_ms)
        return Problem{"frame.hard_cap_ms", literal(c.frame.hard_cap_ms) + " is below frame.budget_ms (" +
                                                literal(c.frame.budget_ms) + "): every frame would be a stall"};
    // The watchdog must outlast the longest frame we still tolerate, or a slow frame kills us.
    if (c.frame.watchdog_s * 1000 <= c.frame.hard_cap_ms)
        return Problem{"frame.watchdog_s", literal(c.frame.watchdog_s) + " s is not longer than frame.hard_cap_ms (" +
                                               literal(c.frame.hard_cap_ms) + " ms)"};
    // Equirect maps are twice as wide as high (docs/conventions.md).
    if (c.capture.map_width != 2 * c.capture.map_height)
        return Problem{"capture.map_width", std::to_string(c.capture.map_width) + " is not twice capture.map_height (" +
                                                std::to_string(c.capture.map_height) + "): an equirect map is 2:1"};
    if (!c.gpio.chip.empty()) {
        const std::vector<std::pair<std::string, int>> lines = {
            {"gpio.button_line", c.gpio.button_line}, {"gpio.key_switch_line", c.gpio.key_switch_line}, {"gpio.lamp_line", c.gpio.lamp_line}};
        for (std::size_t a = 0; a < lines.size(); ++a)
            for (std::size_t b = a + 1; b < lines.size(); ++b)
                if (lines[a].second >= 0 && lines[a].second == lines[b].second)
                    return Problem{lines[b].first, "line " + std::to_string(lines[b].second) + " is also " + lines[a].first};
    }
    // A state dir that holds the export mount point would copy exports into what is exported.
    if (c.state.export_dir == c.state.dir)
        return Problem{"state.export_dir", "'" + c.state.export_dir + "' is the state directory itself"};
    return std::nullopt;
}

std::string where(const std::string& source, std::uint32_t line) {
    return line ? source + ":" + std::to_string(line) : source;
}

Config parse(const std::string& text, const std::string& source, const std::filesystem::path& file) {
    toml::table root;
    try {
        root = toml::parse(text, source);
    } catch (const toml::parse_error& e) {
        throw ConfigError(where(source, e.source().begin.line) + ": TOML syntax: " + std::string(e.description()));
    }
    Config config;
    config.file = file;
    std::map<std::string, std::uint32_t> lines;  // key name -> line it was read from
    // toml++ iterates tables by key, not in file order: every problem is collected and the one
    // nearest the top of the file is reported, as a reader of the file would meet it.
    std::optional<std::pair<std::uint32_t, std::string>> first;
    const auto note = [&](std::uint32_t line, const std::string& message) {
        if (!first || line < first->first) first = {line, where(source, line) + ": " + message};
    };
    const auto sections = config_sections();
    for (auto&& [section_key, section_node] : root) {
        const std::string section(section_key.str());
        const std::uint32_t section_line = section_key.source().begin.line;
        if (std::find(sections.begin(), sections.end(), section) == sections.end()) {
            const char* what = section_node.is_table() ? "unknown section" : "unknown key at the top level";
            note(section_line, "key '" + section + "': " + what + " (sections: " + join(sections) + ")");
            continue;
        }
        const auto* table = section_node.as_table();
        if (!table) {
            note(section_line, "key '" + section + "': must be a table ([" + section + "]), not " + type_name(section_node));
            continue;
        }
        for (auto&& [name_key, value] : *table) {
            const std::string name = section + "." + std::string(name_key.str());
            const std::uint32_t line = name_key.source().begin.line;
            const Key* k = find_key(name);
            if (!k) {
                std::vector<std::string> known;
                for (const auto& other : keys())
                    if (other.info.section == section) known.push_back(other.info.key);
                note(line, "key '" + name + "': unknown key (" + section + " has " + join(known) + ")");
                continue;
            }
            try {
                k->read(config, value);
            } catch (const Reason& r) {
                note(value.source().begin.line ? value.source().begin.line : line, "key '" + name + "': " + r.text);
            }
            lines[name] = line;
        }
    }
    if (first) throw ConfigError(first->second);
    // Rules across keys are checked once every key is valid on its own.
    if (auto p = cross_check(config)) {
        const auto it = lines.find(p->key);
        throw ConfigError(where(source, it == lines.end() ? 0 : it->second) + ": key '" + p->key + "': " + p->why);
    }
    return config;
}

}  // namespace

const std::vector<ConfigKeyInfo>& config_keys() {
    static const std::vector<ConfigKeyInfo> infos = [] {
        std::vector<ConfigKeyInfo> out;
        for (const auto& k : keys()) out.push_back(k.info);
        return out;
    }();
    return infos;
}

std::vector<std::string> config_sections() {
    std::vector<std::string> out;
    for (const auto& k : keys())
        if (out.empty() || out.back() != k.info.section) out.push_back(k.info.section);
    return out;
}

std::vector<std::string> changed_keys(const Config& a, const Config& b) {
    std::vector<std::string> out;
    for (const auto& k : keys())
        if (!k.same(a, b)) out.push_back(k.info.name());
    return out;
}

bool same_values(const Config& a, const Config& b) { return changed_keys(a, b).empty(); }

void copy_key(Config& to, const Config& from, const std::string& name) {
    const Key* k = find_key(name);
    if (!k) throw std::invalid_argument("copy_key: '" + name + "' is not a configuration key");
    k->copy(to, from);
}

std::string format_value(const Config& config, const std::string& name) {
    const Key* k = find_key(name);
    if (!k) throw std::invalid_argument("format_value: '" + name + "' is not a configuration key");
    return k->format(config);
}

std::string to_toml(const Config& config) {
    std::string out;
    std::string section;
    for (const auto& k : keys()) {
        if (k.info.section != section) {
            section = k.info.section;
            out += (out.empty() ? "[" : "\n[") + section + "]\n";
        }
        out += k.info.key + " = " + k.format(config) + "\n";
    }
    return out;
}

Config parse_config(const std::string& text, const std::string& source_name) {
    return parse(text, source_name, source_name);
}

Config load_config(const std::filesystem::path& file) {
    std::error_code ec;
    if (std::filesystem::is_directory(file, ec)) throw ConfigError(file.string() + ": is a directory, not a config file");
    std::ifstream in(file, std::ios::binary);
    if (!in) throw ConfigError(file.string() + ": cannot open: " + std::strerror(errno));
    std::ostringstream text;
    text << in.rdbuf();
    if (in.bad()) throw ConfigError(file.string() + ": cannot read: " + std::strerror(errno));
    return parse(text.str(), file.string(), file);
}

Config default_config() {
    Config c;
    // The defaults are held to the same checks as a file's values: a default edited out of range
    // in config.hpp fails here, in every test, rather than on an appliance.
    for (const auto& k : keys())
        if (auto why = k.check(c)) throw std::logic_error("default of '" + k.info.name() + "': " + *why);
    if (auto p = cross_check(c)) throw std::logic_error("defaults: key '" + p->key + "': " + p->why);
    return c;
}

}  // namespace glint::ui
