// The frame's budget (docs/kiosk.md, "Frame budget"): each frame is timed in its phases — camera
// upload, tracking, rendering, the overlay, presenting — and what is left of the budget goes to
// the background work (the map's convolution tiles, render/live_maps.hpp). Frame times are kept
// per kiosk state for summary.json (median, p99, max) and a frame over the hard cap is counted.
#pragma once

#include <array>
#include <cstdint>
#include <chrono>
#include <map>
#include <string>
#include <vector>

#include "appliance/ui/screen_model.hpp"

namespace glint::ui {

// Flow: the state machine's checks and what they start or take in (a finished scan, the scene's
// maps swapped in, the shadow and final maps' jobs started).
enum class FramePhase : int { Camera = 0, Flow, Tracking, Render, Overlay, Present, Background, Count };
const char* frame_phase_name(FramePhase phase);

struct FrameTimes {
    // The frame thread's time per frame: the last kWindow frames (a ring once full, so that a kiosk
    // running for months keeps a fixed 512 KiB per series), and how many frames there were.
    static constexpr std::size_t kWindow = 65536;  // 36 min at 30 Hz; a whole replay
    std::vector<double> ms;
    std::uint64_t count = 0;
    void add(double frame_ms) {
        if (ms.size() < kWindow) ms.push_back(frame_ms);
        else ms[std::size_t(count % kWindow)] = frame_ms;
        ++count;
    }
    double median() const;
    double p99() const;
    double max() const;
};

class FrameScheduler {
public:
    using Clock = std::chrono::steady_clock;
    // keep_records: every frame's record for a frame log (a replay's frames.csv); off for the live
    // appliance, whose loop runs for months (the per-state times stay bounded either way).
    FrameScheduler(double budget_ms, double hard_cap_ms, bool keep_records = true)
        : budget_ms_(budget_ms), hard_cap_ms_(hard_cap_ms), keep_records_(keep_records) {}

    void begin_frame(KioskState state);
    // The time since the last mark (or the frame's start) is charged to `phase`.
    void mark(FramePhase phase);
    // The time since the last mark is not the appliance's (a replay waiting for its capture to
    // keep step, a snapshot written for the replay's record): left out of the frame's time.
    void exclude_since_mark();
    // What the frame has used so far, and what is left of the budget (0 when over).
    double used_ms() const;
    double left_ms() const;
    // Ends the frame; returns its time (background work charged with mark(Background) counts).
    double end_frame();

    double budget_ms() const { return budget_ms_; }
    double hard_cap_ms() const { return hard_cap_ms_; }
    void set_budget(double budget_ms, double hard_cap_ms) { budget_ms_ = budget_ms; hard_cap_ms_ = hard_cap_ms; }
    int frames() const { return frames_; }
    int over_cap() const { return over_cap_; }
    double worst_ms() const { return all_.max(); }
    const FrameTimes& all() const { return all_; }
    const std::map<KioskState, FrameTimes>& by_state() const { return by_state_; }
    // Mean ms a frame spent in each phase, over every frame.
    std::array<double, int(FramePhase::Count)> phase_means() const;
    // Every frame: its state, its time and each phase's (for `glint replay --frame-log`).
    struct FrameRecord {
        KioskState state;
        double ms;
        std::array<double, int(FramePhase::Count)> phase_ms;
    };
    const std::vector<FrameRecord>& records() const { return records_; }

private:
    double budget_ms_, hard_cap_ms_;
    bool keep_records_ = true;
    KioskState state_ = KioskState::Attract;
    Clock::time_point start_, last_;
    double excluded_ms_ = 0;
    std::array<double, int(FramePhase::Count)> phase_sum_{}, phase_now_{};
    std::vector<FrameRecord> records_;
    FrameTimes all_;
    std::map<KioskState, FrameTimes> by_state_;
    int frames_ = 0, over_cap_ = 0;
};

}  // namespace glint::ui
