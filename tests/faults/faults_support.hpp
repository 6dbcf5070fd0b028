// Helpers of the fault tests: a temporary state directory and file edits.
#pragma once

#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <random>
#include <sstream>
#include <string>
#include <vector>

namespace glint::faults {

class TempDir {
public:
    explicit TempDir(const std::filesystem::path& under = std::filesystem::temp_directory_path()) {
        std::random_device rd;
        path_ = under / ("glint-faults-" + std::to_string(::getpid()) + "-" + std::to_string(rd()));
        std::filesystem::create_directories(path_);
    }
    TempDir(const TempDir&) = delete;
    TempDir& operator=(const TempDir&) = delete;
    ~TempDir() {
        std::error_code ec;
        std::filesystem::remove_all(path_, ec);
    }
    const std::filesystem::path& path() const { return path_; }

private:
    std::filesystem::path path_;
};

inline std::string read_text(const std::filesystem::path& p) {
    std::ifstream in(p, std::ios::binary);
    std::stringstream text;
    text << in.rdbuf();
    return text.str();
}

inline void write_text(const std::filesystem::path& p, const std::string& text) {
    std::ofstream(p, std::ios::binary | std::ios::trunc) << text;
}

// The directories under <dir>/corrupt/ (each a set-aside).
inline std::vector<std::filesystem::path> set_asides(const std::filesystem::path& state_dir) {
    std::vector<std::filesystem::path> out;
    std::error_code ec;
    for (const auto& e : std::filesystem::directory_iterator(state_dir / "corrupt", ec)) out.push_back(e.path());
    return out;
}

}  // namespace glint::faults
