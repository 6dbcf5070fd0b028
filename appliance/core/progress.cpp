// Terminal progress bar: redrawn at most 10 times a second, never on a pipe.
#include "appliance/core/progress.hpp"

#include <unistd.h>

#include <algorithm>
#include <cstdio>

namespace glint {

ProgressBar::ProgressBar(std::string label, long long total)
    : label_(std::move(label)), total_(total > 0 ? total : 1), enabled_(::isatty(2) == 1),
      last_draw_(std::chrono::steady_clock::now()), start_(last_draw_) {}

ProgressBar::~ProgressBar() { finish(); }

void ProgressBar::advance(long long units) {
    done_.fetch_add(units, std::memory_order_relaxed);
    if (!enabled_) return;
    const auto now = std::chrono::steady_clock::now();
    std::unique_lock lock(mutex_, std::try_to_lock);
    if (!lock.owns_lock() || now - last_draw_ < std::chrono::milliseconds(100)) return;
    last_draw_ = now;
    draw(false);
}

void ProgressBar::finish() {
    if (!enabled_ || finished_) return;
    std::lock_guard lock(mutex_);
    finished_ = true;
    // Only leave a line behind when the work took long enough to be seen.
    if (std::chrono::steady_clock::now() - start_ > std::chrono::milliseconds(300)) draw(true);
}

void ProgressBar::draw(bool final_line) {
    const double frac = std::min(1.0, double(done_.load()) / double(total_));
    constexpr int kWidth = 30;
    const int filled = int(frac * kWidth);
    char bar[kWidth + 1];
    for (int i = 0; i < kWidth; ++i) bar[i] = i < filled ? '#' : '.';
    bar[kWidth] = 0;
    const double secs =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
    std::fprintf(stderr, "\r%-28s [%s] %3d%% %6.1fs%s", label_.c_str(), bar, int(frac * 100),
                 secs, final_line ? "\n" : "");
    std::fflush(stderr);
}

std::function<void(long long, long long)> progress_callback(std::string label) {
    struct State {
        std::string label;
        std::mutex mutex;
        std::unique_ptr<ProgressBar> bar;
        long long done = 0;
    };
    auto state = std::make_shared<State>();
    state->label = std::move(label);
    return [state](long long done, long long total) {
        std::lock_guard lock(state->mutex);
        if (!state->bar) state->bar = std::make_unique<ProgressBar>(state->label, total);
        if (done > state->done) {  // workers may report out of order
            state->bar->advance(done - state->done);
            state->done = done;
        }
    };
}

}  // namespace glint
