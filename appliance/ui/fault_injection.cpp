#include "appliance/ui/fault_injection.hpp"

#include <opencv2/imgproc.hpp>

#include <chrono>
#include <thread>

#include "appliance/core/errors.hpp"
#include "appliance/core/strict_number.hpp"

namespace glint::ui {

namespace {

std::vector<std::string> split(const std::string& text, char separator) {
    std::vector<std::string> parts;
    std::size_t start = 0;
    while (true) {
        const std::size_t end = text.find(separator, start);
        parts.push_back(text.substr(start, end == std::string::npos ? std::string::npos : end - start));
        if (end == std::string::npos) return parts;
        start = end + 1;
    }
}

}  // namespace

FaultPlan parse_fault_plan(const std::string& spec, const std::string& flag) {
    FaultPlan plan;
    for (const std::string& item : split(spec, ',')) {
        if (item.empty()) continue;
        const std::vector<std::string> f = split(item, ':');
        const std::string where = flag + " '" + item + "'";
        const auto number = [&](std::size_t k) {
            const double v = parse_double(f[k], where);
            if (!(v >= 0)) throw InputError(where + ": times are seconds from the kiosk's start, 0 or more");
            return v;
        };
        const auto window = [&] {
            if (f.size() != 3) throw InputError(where + ": expected " + f[0] + ":FROM:TO");
            const FaultWindow w{number(1), number(2)};
            if (!(w.to_s > w.from_s)) throw InputError(where + ": TO must be after FROM");
            return w;
        };
        if (f[0] == "sensor-gap") plan.sensor_gaps.push_back(window());
        else if (f[0] == "camera-stall") plan.camera_stalls.push_back(window());
        else if (f[0] == "camera-shuffle") plan.camera_shuffles.push_back(window());
        else if (f[0] == "camera-mode") plan.camera_modes.push_back(window());
        else if (f[0] == "loop-stall") {
            if (f.size() != 3) throw InputError(where + ": expected loop-stall:AT:SECONDS");
            const double at = number(1), seconds = number(2);
            if (!(seconds > 0 && seconds <= 600)) throw InputError(where + ": SECONDS must be in (0, 600]");
            plan.loop_stall = FaultWindow{at, at + seconds};
        } else if (f[0] == "input-flood") {
            if (f.size() != 4) throw InputError(where + ": expected input-flood:FROM:TO:EVENTS_PER_S");
            const FaultWindow w{number(1), number(2)};
            if (!(w.to_s > w.from_s)) throw InputError(where + ": TO must be after FROM");
            const double rate = number(3);
            if (!(rate > 0 && rate <= 1e6)) throw InputError(where + ": EVENTS_PER_S must be in (0, 1e6]");
            plan.input_floods.push_back({w, rate});
        } else if (f[0] == "gl-lost") {
            if (f.size() != 2) throw InputError(where + ": expected gl-lost:AT");
            plan.gl_lost_at_s = number(1);
        } else {
            throw InputError(where + ": unknown fault '" + f[0] +
                             "' (sensor-gap, camera-stall, camera-shuffle, camera-mode, loop-stall, gl-lost, input-flood)");
        }
    }
    return plan;
}

FaultInjectingSource::FaultInjectingSource(KioskSource& inner, FaultPlan plan, std::function<void(const std::string&)> log)
    : inner_(inner), plan_(std::move(plan)), log_(std::move(log)),
      announced_(plan_.sensor_gaps.size() + plan_.camera_stalls.size() + plan_.camera_shuffles.size() +
                     plan_.camera_modes.size(),
                 false) {}

bool FaultInjectingSource::in_sensor_gap(std::int64_t t_ns) const {
    const double t = seconds(t_ns);
    for (const FaultWindow& w : plan_.sensor_gaps)
        if (w.contains(t)) return true;
    return false;
}

void FaultInjectingSource::configure_capture(capture::CaptureOptions& options) {
    inner_.configure_capture(options);
    // A live capture looks the orientation up itself: the gap hides it there too.
    if (options.live_orientation)
        options.live_orientation = [this, lookup = options.live_orientation](std::int64_t t_ns) -> std::optional<glm::dquat> {
            if (in_sensor_gap(t_ns)) return std::nullopt;
            return lookup(t_ns);
        };
}

KioskPoll FaultInjectingSource::poll(std::int64_t now_ns) {
    const double t = seconds(now_ns);
    if (plan_.loop_stall && !loop_stalled_ && t >= plan_.loop_stall->from_s) {
        loop_stalled_ = true;
        if (log_) log_("fault injected: the frame loop blocks for " + std::to_string(plan_.loop_stall->to_s - plan_.loop_stall->from_s) + " s");
        std::this_thread::sleep_for(std::chrono::duration<double>(plan_.loop_stall->to_s - plan_.loop_stall->from_s));
    }
    std::size_t k = 0;
    const auto announce = [&](const std::vector<FaultWindow>& windows, const char* what) {
        for (const FaultWindow& w : windows) {
            if (w.contains(t) && !announced_[k] && log_) {
                announced_[k] = true;
                log_(std::string("fault injected: ") + what + " from " + std::to_string(w.from_s) + " to " + std::to_string(w.to_s) + " s");
            }
            ++k;
        }
    };
    announce(plan_.sensor_gaps, "sensor gap");
    announce(plan_.camera_stalls, "camera stall");
    announce(plan_.camera_shuffles, "frames out of order");
    announce(plan_.camera_modes, "frames at half the camera's size");
    for (const FaultPlan::Flood& flood : plan_.input_floods)
        if (!flood.window.contains(t) && t >= flood.window.to_s && flood_events_ > 0 && log_) {
            log_("fault injected: an input flood of " + std::to_string(flood_events_) + " events ended");
            flood_events_ = 0;
        }

    KioskPoll p = inner_.poll(now_ns);
    // The flood: events spread over the time since the last poll.
    const double dt = last_poll_ns_ ? double(now_ns - *last_poll_ns_) * 1e-9 : 0;
    last_poll_ns_ = now_ns;
    for (const FaultPlan::Flood& flood : plan_.input_floods) {
        if (!flood.window.contains(t)) continue;
        flood_owed_ += flood.events_per_s * dt;
        static const char* const kKeys[] = {"0", "1", "2", "3", "4", "5", "6", "7", "8", "9", "Return", "Escape",
                                            "space", "BackSpace", "Control_L", "Alt_L", "m", "F1", "F4", "F7", "F8",
                                            "Up", "Down", "Left", "Right", "Prior", "Next", "Tab", "q"};
        const auto next = [&] {  // xorshift64*
            flood_state_ ^= flood_state_ >> 12;
            flood_state_ ^= flood_state_ << 25;
            flood_state_ ^= flood_state_ >> 27;
            return flood_state_ * 0x2545F4914F6CDD1Dull;
        };
        for (; flood_owed_ >= 1; flood_owed_ -= 1) {
            const std::uint64_t r = next();
            if (r % 2 == 0) p.events.push_back({now_ns, "button", (r >> 8) % 2 ? "press" : "release"});
            else p.events.push_back({now_ns, (r >> 8) % 2 ? "key" : "key_up", kKeys[(r >> 16) % std::size(kKeys)]});
            ++flood_events_;
        }
    }
    std::erase_if(p.orientations, [&](const capture::SensorOrientation& s) { return in_sensor_gap(s.t_ns); });
    for (const FaultWindow& w : plan_.camera_stalls)
        if (w.contains(t)) p.frames.clear();
    for (const FaultWindow& w : plan_.camera_modes)
        if (w.contains(t))
            for (capture::CameraFrame& f : p.frames) {
                cv::Mat half;
                cv::resize(f.rgb, half, cv::Size(std::max(1, f.rgb.cols / 2), std::max(1, f.rgb.rows / 2)), 0, 0,
                           cv::INTER_AREA);
                f.rgb = half;
            }
    bool shuffling = false;
    for (const FaultWindow& w : plan_.camera_shuffles) shuffling = shuffling || w.contains(t);
    if (shuffling || held_) {
        // Each pair of frames leaves in swapped order; a frame held at the window's end follows
        // the next one.
        std::vector<capture::CameraFrame> out;
        for (capture::CameraFrame& f : p.frames) {
            if (held_) {
                out.push_back(std::move(f));
                out.push_back(std::move(*held_));
                held_.reset();
            } else if (shuffling) {
                held_ = std::move(f);
            } else {
                out.push_back(std::move(f));
            }
        }
        p.frames = std::move(out);
    }
    return p;
}

std::optional<glm::dquat> FaultInjectingSource::world_from_sensor(std::int64_t sensor_t_ns) const {
    if (in_sensor_gap(sensor_t_ns)) return std::nullopt;
    return inner_.world_from_sensor(sensor_t_ns);
}

std::string FaultInjectingSource::restart_camera() { return inner_.restart_camera(); }

}  // namespace glint::ui
