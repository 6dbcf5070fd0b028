// The configuration's keys as data (docs/service.md, "The configuration file"): one entry per
// field of Config, named "section.key", with whether a SIGHUP may apply a new value live. The
// reload (config_reload.hpp), the tests that keep config.hpp, the parser and the shipped example
// in step, and the writer of a config file all go through this one list.
#pragma once

#include <string>
#include <vector>

#include "appliance/ui/config.hpp"

namespace glint::ui {

struct ConfigKeyInfo {
    std::string section;  // "display"
    std::string key;      // "kind"
    // true: the running kiosk takes a new value on SIGHUP (timeouts, frame budget, capture,
    // convolution, materials, the PIN); false: it is read once at start (devices, state dir).
    bool live = false;
    std::string name() const { return section + "." + key; }
};

// Every key, in the order of config.hpp (and of the shipped example).
const std::vector<ConfigKeyInfo>& config_keys();
// The sections in file order: display, camera, ..., state.
std::vector<std::string> config_sections();

// Names ("section.key") of the keys whose values differ between `a` and `b`, in file order.
std::vector<std::string> changed_keys(const Config& a, const Config& b);
// Whether every key is equal (Config::file is not a key and is ignored).
bool same_values(const Config& a, const Config& b);
// Copies the value of key `name` ("section.key") from `from` into `to`. Throws
// std::invalid_argument for a name that is not a key.
void copy_key(Config& to, const Config& from, const std::string& name);

// The value of key `name` as a TOML literal ("\"auto\"", "1280", "33.333", "true", "[\"a\"]").
std::string format_value(const Config& config, const std::string& name);
// `config` as a complete TOML file, every section and key in file order, that load_config reads
// back to the same values (for a settings page that saves; written with core/atomic_file).
std::string to_toml(const Config& config);
// Parses and validates TOML text as load_config does; `source_name` stands for the file in
// error messages.
Config parse_config(const std::string& text, const std::string& source_name);

}  // namespace glint::ui
