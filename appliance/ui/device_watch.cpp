#include "appliance/ui/device_watch.hpp"

#include <cstdio>

namespace glint::ui {

namespace {

std::string seconds_text(double s) {
    char text[32];
    std::snprintf(text, sizeof text, "%.1f s", s);
    return text;
}

void slide(std::deque<std::pair<double, std::size_t>>& window, double t_s, std::size_t count) {
    if (count > 0) window.emplace_back(t_s, count);
    while (!window.empty() && window.front().first <= t_s - 1.0) window.pop_front();
}

double per_second(const std::deque<std::pair<double, std::size_t>>& window) {
    std::size_t n = 0;
    for (const auto& [t, count] : window) n += count;
    return double(n);
}

}  // namespace

DeviceWatch::DeviceWatch(DeviceWatchSettings settings, double start_s)
    : settings_(settings), t_s_(start_s), last_frame_s_(start_s), last_sample_s_(start_s) {}

bool DeviceWatch::accept_frame(std::int64_t t_ns) {
    if (have_frame_time_ && t_ns <= last_frame_t_ns_) {
        ++counts_.frames_out_of_order;
        return false;
    }
    have_frame_time_ = true;
    last_frame_t_ns_ = t_ns;
    return true;
}

DeviceWatch::Step DeviceWatch::update(double t_s, std::size_t frames, std::size_t samples) {
    Step step;
    t_s_ = t_s;
    slide(frames_window_, t_s, frames);
    slide(samples_window_, t_s, samples);

    if (frames > 0) {
        last_frame_s_ = t_s;
        if (camera_lost_) {
            camera_lost_ = false;
            counts_.camera_lost_s += t_s - camera_lost_since_s_;
            step.log.push_back("camera: frames again after " + seconds_text(t_s - camera_lost_since_s_));
        }
    } else if (t_s - last_frame_s_ > settings_.camera_stall_s) {
        if (!camera_lost_) {
            camera_lost_ = true;
            camera_lost_since_s_ = last_frame_s_;
            ++counts_.camera_losses;
            step.log.push_back("camera: no frame for " + seconds_text(t_s - last_frame_s_) + "; restarting it");
        }
        // At once, then every camera_stall_s while it stays silent.
        if (t_s - last_restart_s_ >= settings_.camera_stall_s) {
            step.restart_camera = true;
            last_restart_s_ = t_s;
        }
    }

    // Frames out of order, journalled at the 1st, 10th, 100th, ... (a broken camera must not flood it).
    if (counts_.frames_out_of_order >= next_out_of_order_log_) {
        step.log.push_back("camera: " + std::to_string(counts_.frames_out_of_order) +
                           " frame(s) out of order dropped so far");
        next_out_of_order_log_ = counts_.frames_out_of_order * 10;
    }

    if (samples > 0) {
        last_sample_s_ = t_s;
        if (sensor_lost_) {
            sensor_lost_ = false;
            counts_.sensor_lost_s += t_s - sensor_lost_since_s_;
            step.log.push_back("sensor: orientation again after " + seconds_text(t_s - sensor_lost_since_s_));
        }
    } else if (!sensor_lost_ && t_s - last_sample_s_ > settings_.sensor_lost_after_s) {
        sensor_lost_ = true;
        sensor_lost_since_s_ = last_sample_s_;
        ++counts_.sensor_losses;
        step.log.push_back("sensor: no orientation for " + seconds_text(t_s - last_sample_s_));
    }
    return step;
}

std::string DeviceWatch::camera_restarted(double, const std::string& error) {
    if (error.empty()) {
        ++counts_.camera_restarts;
        return "camera: restarted (" + std::to_string(counts_.camera_restarts) + " so far)";
    }
    ++counts_.camera_restart_failures;
    return "camera: restart failed: " + error + " (trying again in " + seconds_text(settings_.camera_stall_s) + ")";
}

double DeviceWatch::camera_fps() const { return per_second(frames_window_); }
double DeviceWatch::sensor_rate_hz() const { return per_second(samples_window_); }

}  // namespace glint::ui
