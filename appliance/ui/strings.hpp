// Every text a visitor or a technician reads, from one resource file (data/ui/strings.toml), looked
// up by key ("processing.adjusting", "material.matte", "menu.page.status"). Tables nest: the key
// "capture.exposure.too_bright" is [capture.exposure] too_bright = "...". A text may hold named
// places, "{s} s left", filled by format(). The code's keys are listed once (ui_string_keys());
// loading a file that lacks one of them is an error, so a missing translation never reaches a
// screen.
#pragma once

#include <filesystem>
#include <map>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace glint::ui {

class Strings {
public:
    // Reads `file`. Throws InputError naming the file (and the line, for a TOML syntax error) when
    // it cannot be read, a value is not a string, or a key of `required` is missing (every missing
    // key is named).
    static Strings load(const std::filesystem::path& file, const std::vector<std::string>& required);
    // ... with the keys the code uses (ui_string_keys()).
    static Strings load(const std::filesystem::path& file);
    // From texts already in memory (tests).
    explicit Strings(std::map<std::string, std::string> texts, std::filesystem::path file = {});
    Strings() = default;

    bool has(std::string_view key) const;
    // The text of `key`. A key the code uses is always there (load checked); a key that comes
    // from elsewhere (a material named in the config, a message key from the kiosk) and is not in
    // the file shows as the key itself: a frame is never lost to a missing text.
    const std::string& get(std::string_view key) const;
    // get() with every "{name}" replaced by its value; an unknown place stays as written.
    std::string format(std::string_view key, const std::vector<std::pair<std::string, std::string>>& values) const;
    // Every key of the file, sorted.
    std::vector<std::string> keys() const;
    const std::filesystem::path& file() const { return file_; }

private:
    std::map<std::string, std::string, std::less<>> texts_;
    std::filesystem::path file_;
    mutable std::map<std::string, std::string, std::less<>> missing_;  // keys shown as themselves
};

// The keys the screens and the menu use, sorted (the test compares them with the file both ways).
const std::vector<std::string>& ui_string_keys();

// Where the shipped strings file is, relative to the source or install tree: data/ui/strings.toml.
inline constexpr const char* kStringsRelativePath = "data/ui/strings.toml";

}  // namespace glint::ui
