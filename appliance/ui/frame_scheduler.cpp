#include "appliance/ui/frame_scheduler.hpp"

#include <algorithm>
#include <cmath>

namespace glint::ui {

const char* frame_phase_name(FramePhase phase) {
    switch (phase) {
        case FramePhase::Camera: return "camera";
        case FramePhase::Flow: return "flow";
        case FramePhase::Tracking: return "tracking";
        case FramePhase::Render: return "render";
        case FramePhase::Overlay: return "overlay";
        case FramePhase::Present: return "present";
        case FramePhase::Background: return "background";
        case FramePhase::Count: break;
    }
    return "?";
}

namespace {
// The q-quantile by the nearest rank (p99 of 100 frames is the 99th smallest).
double quantile(std::vector<double> v, double q) {
    if (v.empty()) return 0;
    std::sort(v.begin(), v.end());
    const std::size_t rank = std::size_t(std::ceil(q * double(v.size())));
    return v[std::clamp<std::size_t>(rank, 1, v.size()) - 1];
}
}  // namespace

double FrameTimes::median() const { return quantile(ms, 0.5); }
double FrameTimes::p99() const { return quantile(ms, 0.99); }
double FrameTimes::max() const { return ms.empty() ? 0 : *std::max_element(ms.begin(), ms.end()); }

void FrameScheduler::begin_frame(KioskState state) {
    state_ = state;
    start_ = last_ = Clock::now();
    excluded_ms_ = 0;
    phase_now_ = {};
}

void FrameScheduler::exclude_since_mark() {
    const Clock::time_point now = Clock::now();
    excluded_ms_ += std::chrono::duration<double, std::milli>(now - last_).count();
    last_ = now;
}

void FrameScheduler::mark(FramePhase phase) {
    const Clock::time_point now = Clock::now();
    const double ms = std::chrono::duration<double, std::milli>(now - last_).count();
    phase_sum_[int(phase)] += ms;
    phase_now_[int(phase)] += ms;
    last_ = now;
}

double FrameScheduler::used_ms() const {
    return std::chrono::duration<double, std::milli>(Clock::now() - start_).count() - excluded_ms_;
}

double FrameScheduler::left_ms() const { return std::max(0.0, budget_ms_ - used_ms()); }

double FrameScheduler::end_frame() {
    const double ms = used_ms();
    all_.add(ms);
    by_state_[state_].add(ms);
    ++frames_;
    if (ms > hard_cap_ms_) ++over_cap_;
    if (keep_records_) records_.push_back({state_, ms, phase_now_});
    return ms;
}

std::array<double, int(FramePhase::Count)> FrameScheduler::phase_means() const {
    std::array<double, int(FramePhase::Count)> m{};
    for (int k = 0; k < int(FramePhase::Count); ++k) m[k] = frames_ > 0 ? phase_sum_[k] / frames_ : 0;
    return m;
}

}  // namespace glint::ui
