// Faults injected into the kiosk's inputs, for tests and for an engineer checking how the appliance
// rides out a device that misbehaves (docs/kiosk.md, "Devices that misbehave"): `glint run` and
// `glint replay` take `--inject-fault SPEC`. The kiosk itself cannot tell an injected fault from
// a real one: the wrapper below withholds what the real source delivered, so everything after it
// (the sensor-lost pause, the camera restart, the out-of-order filter, the watchdog) is the code
// that runs on the appliance.
//
// SPEC is a comma-separated list; times are seconds on the kiosk's clock (0 = its start):
//   sensor-gap:FROM:TO      no orientation samples and no orientation lookups in [FROM, TO)
//                           (a sensor cable pulled, then plugged in again)
//   camera-stall:FROM:TO    no camera frames in [FROM, TO) (a camera that stops delivering; its
//                           restart does not end the window: the kiosk must keep trying)
//   camera-shuffle:FROM:TO  frames in [FROM, TO) delivered in swapped pairs (out of order)
//   camera-mode:FROM:TO     frames in [FROM, TO) at half the width and height (a camera that
//                           switched its sensor mode: not the calibration's size)
//   loop-stall:AT:SECONDS   the frame loop blocks once for SECONDS at AT (the watchdog's test)
//   gl-lost:AT              the GL context reports itself lost at AT (a GPU reset)
//   input-flood:FROM:TO:RATE  RATE input events a second in [FROM, TO): half of them presses and
//                           releases of the visitor's button, half random keys going down and up
//                           (digits, Return, Escape, the menu chord's modifiers and letter,
//                           function and arrow keys), from a fixed seed (a visitor mashing buttons)
#pragma once

#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "appliance/ui/kiosk_source.hpp"

namespace glint::ui {

struct FaultWindow {
    double from_s = 0, to_s = 0;
    bool contains(double t_s) const { return t_s >= from_s && t_s < to_s; }
};

struct FaultPlan {
    std::vector<FaultWindow> sensor_gaps, camera_stalls, camera_shuffles, camera_modes;
    struct Flood {
        FaultWindow window;
        double events_per_s = 0;
    };
    std::vector<Flood> input_floods;
    std::optional<FaultWindow> loop_stall;  // from_s = when, to_s - from_s = how long
    std::optional<double> gl_lost_at_s;
    bool empty() const {
        return sensor_gaps.empty() && camera_stalls.empty() && camera_shuffles.empty() && camera_modes.empty() &&
               input_floods.empty() && !loop_stall && !gl_lost_at_s;
    }
};

// The commands' help for --inject-fault.
inline constexpr std::string_view kInjectFaultHelp =
    "Faults for tests (docs/kiosk.md, \"Devices that misbehave\"), comma-separated, times in kiosk seconds: "
    "sensor-gap:FROM:TO, camera-stall:FROM:TO, camera-shuffle:FROM:TO, camera-mode:FROM:TO, loop-stall:AT:SECONDS, "
    "gl-lost:AT, "
    "input-flood:FROM:TO:EVENTS_PER_S";

// Throws InputError naming `flag` and the item at fault.
FaultPlan parse_fault_plan(const std::string& spec, const std::string& flag = "--inject-fault");

// `inner` with the plan's faults applied; `log` hears each fault as it starts.
class FaultInjectingSource final : public KioskSource {
public:
    FaultInjectingSource(KioskSource& inner, FaultPlan plan, std::function<void(const std::string&)> log);

    std::string describe() const override { return inner_.describe(); }
    const capture::CameraCalibration& calibration() const override { return inner_.calibration(); }
    const render::CameraResponse& response() const override { return inner_.response(); }
    std::string board_json() const override { return inner_.board_json(); }
    void configure_capture(capture::CaptureOptions& options) override;
    std::int64_t start_ns() const override { return inner_.start_ns(); }
    KioskPoll poll(std::int64_t now_ns) override;
    std::optional<glm::dquat> world_from_sensor(std::int64_t sensor_t_ns) const override;
    bool ended(std::int64_t now_ns) const override { return inner_.ended(now_ns); }
    void set_scanning(bool scanning) override { inner_.set_scanning(scanning); }
    std::string exposure_state() const override { return inner_.exposure_state(); }
    std::string restart_camera() override;
    SourceHealth health() const override { return inner_.health(); }
    void set_lamp(LampMode mode) override { inner_.set_lamp(mode); }
    bool replayed() const override { return inner_.replayed(); }
    std::optional<std::int64_t> scan_end_ns() const override { return inner_.scan_end_ns(); }
    bool in_ar_phase(std::int64_t t_ns) const override { return inner_.in_ar_phase(t_ns); }
    std::optional<capture::TruthBoardPose> truth_board(std::uint64_t sequence) const override {
        return inner_.truth_board(sequence);
    }

private:
    double seconds(std::int64_t t_ns) const { return double(t_ns - inner_.start_ns()) * 1e-9; }
    bool in_sensor_gap(std::int64_t t_ns) const;

    KioskSource& inner_;
    FaultPlan plan_;
    std::function<void(const std::string&)> log_;
    std::optional<capture::CameraFrame> held_;  // the first of a pair being swapped
    bool loop_stalled_ = false;
    std::optional<std::int64_t> last_poll_ns_;
    double flood_owed_ = 0;           // events due but not yet made (a fraction carried over)
    std::uint64_t flood_state_ = 0x9E3779B97F4A7C15ull;  // the flood's generator (fixed seed)
    std::uint64_t flood_events_ = 0;
    std::vector<bool> announced_;  // per window, in the order sensor gaps, stalls, shuffles
};

}  // namespace glint::ui
