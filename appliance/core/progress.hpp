// A progress bar on stderr, drawn only when stderr is a terminal.
#pragma once

#include <atomic>
#include <chrono>
#include <functional>
#include <memory>
#include <mutex>
#include <string>

namespace glint {

class ProgressBar {
public:
    // total: units of work; label: what is being done ("irradiance 128x64").
    ProgressBar(std::string label, long long total);
    ~ProgressBar();
    ProgressBar(const ProgressBar&) = delete;
    ProgressBar& operator=(const ProgressBar&) = delete;

    void advance(long long units = 1);  // thread-safe
    void finish();

private:
    void draw(bool final_line);

    std::string label_;
    long long total_;
    std::atomic<long long> done_{0};
    bool enabled_;
    bool finished_ = false;
    std::mutex mutex_;
    std::chrono::steady_clock::time_point last_draw_;
    std::chrono::steady_clock::time_point start_;
};

// A progress callback (done, total) for work that reports cumulative counts, from any thread and
// possibly out of order: draws a ProgressBar made at the first report, finished when the last
// copy of the callback goes.
std::function<void(long long done, long long total)> progress_callback(std::string label);

}  // namespace glint
