// Shared by the libFuzzer targets of tests/fuzz: a failed property check aborts (libFuzzer and
// the GCC replay both report an abort as a crash), a per-process scratch directory in /dev/shm
// for the parsers that read files, and the split of one input into several files.
#pragma once

#include <signal.h>
#include <unistd.h>

#include <cerrno>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>
#include <string_view>
#include <system_error>
#include <vector>

namespace glint::fuzz {

inline void check(bool ok) {
    if (!ok) std::abort();
}

// /dev/shm/glint-fuzz-NAME-PID: in memory (no disk writes per execution), one per process so
// that parallel runs (-jobs, -fork) do not share files; removed at exit. libFuzzer ends its runs
// with _Exit (no atexit handlers), so each process also removes the directories of processes that
// are gone.
inline const std::filesystem::path& scratch_dir(const char* name) {
    static const std::filesystem::path dir = [name] {
        const std::filesystem::path base = std::filesystem::exists("/dev/shm") ? "/dev/shm" : "/tmp";
        std::error_code ec;
        for (const auto& entry : std::filesystem::directory_iterator(base, ec)) {
            const std::string n = entry.path().filename().string();
            if (n.rfind("glint-fuzz-", 0) != 0) continue;
            const std::size_t dash = n.rfind('-');
            const long pid = std::strtol(n.c_str() + dash + 1, nullptr, 10);
            if (pid > 0 && ::kill(pid_t(pid), 0) != 0 && errno == ESRCH) std::filesystem::remove_all(entry.path(), ec);
        }
        std::filesystem::path d = base / ("glint-fuzz-" + std::string(name) + "-" + std::to_string(::getpid()));
        std::filesystem::create_directories(d);
        std::atexit([] {
            std::error_code ignored;
            std::filesystem::remove_all(scratch_dir(nullptr), ignored);
        });
        return d;
    }();
    return dir;
}

// Replaces the directory's contents with nothing.
inline void clear_dir(const std::filesystem::path& dir) {
    std::error_code ec;
    for (const auto& entry : std::filesystem::directory_iterator(dir, ec)) std::filesystem::remove_all(entry.path(), ec);
}

inline void write_file(const std::filesystem::path& path, std::string_view bytes) {
    std::filesystem::create_directories(path.parent_path());
    std::ofstream out(path, std::ios::binary | std::ios::trunc);
    out.write(bytes.data(), std::streamsize(bytes.size()));
    check(bool(out));
}

// The pieces of `input` between occurrences of `separator` (a line of its own in the seeds, so
// they stay readable text): "a\n#---#\nb" -> {"a", "b"}.
inline std::vector<std::string_view> split(std::string_view input, std::string_view separator) {
    std::vector<std::string_view> pieces;
    for (;;) {
        const std::size_t at = input.find(separator);
        if (at == std::string_view::npos) {
            pieces.push_back(input);
            return pieces;
        }
        pieces.push_back(input.substr(0, at));
        input.remove_prefix(at + separator.size());
    }
}

inline std::string_view as_text(const std::uint8_t* data, std::size_t size) {
    return {reinterpret_cast<const char*>(data), size};
}

}  // namespace glint::fuzz
