// The journal's last lines, kept for the maintenance menu's log page: every line the kiosk logs
// goes to stderr (the journal, under systemd) and into this ring. Thread-safe: the capture and
// device threads log too.
#pragma once

#include <chrono>
#include <cstdio>
#include <deque>
#include <mutex>
#include <string>
#include <vector>

namespace glint::app {

class LogTail {
public:
    explicit LogTail(std::size_t capacity = 200) : capacity_(capacity), start_(std::chrono::steady_clock::now()) {}

    // "glint: LINE" on stderr, and "[SECONDS s] LINE" kept.
    void write(const std::string& line) {
        std::fprintf(stderr, "glint: %s\n", line.c_str());
        char stamp[32];
        std::snprintf(stamp, sizeof stamp, "[%8.1f s] ",
                      std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count());
        const std::lock_guard lock(mutex_);
        lines_.push_back(stamp + line);
        while (lines_.size() > capacity_) lines_.pop_front();
    }

    std::vector<std::string> lines() const {
        const std::lock_guard lock(mutex_);
        return {lines_.begin(), lines_.end()};
    }

private:
    std::size_t capacity_;
    std::chrono::steady_clock::time_point start_;
    mutable std::mutex mutex_;
    std::deque<std::string> lines_;
};

}  // namespace glint::app
