#include "appliance/capture/guided_capture.hpp"

#include <algorithm>
#include <cmath>

namespace glint::capture {

const char* guided_state_name(GuidedState s) {
    switch (s) {
        case GuidedState::Scanning: return "scanning";
        case GuidedState::Complete: return "complete";
        case GuidedState::TimedOut: return "timed out";
    }
    return "unknown";
}

const char* exposure_status_name(ExposureStatus s) {
    switch (s) {
        case ExposureStatus::Ok: return "ok";
        case ExposureStatus::TooBright: return "too bright";
        case ExposureStatus::TooDark: return "too dark";
    }
    return "unknown";
}

GuidedCapture::GuidedCapture(GuidedSettings settings, Intrinsics camera) : settings_(settings), camera_(camera) {}

GuidedStep GuidedCapture::update(const CameraFrame& frame, const glm::dquat& q,
                                 const std::vector<std::uint32_t>& samples, int w, int h) {
    GuidedStep s;
    if (!start_ns_) start_ns_ = frame.t_ns;
    if (paused_from_ns_) {
        // Back after a pause: from the first unplaced frame to this one is not scanning time, and
        // the turn since the last placed frame is no speed (the visitor moved while waiting).
        if (frame.t_ns > *paused_from_ns_) paused_ns_ += frame.t_ns - *paused_from_ns_;
        paused_from_ns_.reset();
        previous_t_ns_.reset();
    } else if (last_t_ns_ && double(frame.t_ns - *last_t_ns_) * 1e-9 > settings_.pause_after_gap_s) {
        paused_ns_ += frame.t_ns - *last_t_ns_;
        previous_t_ns_.reset();
    }
    last_t_ns_ = frame.t_ns;
    s.elapsed_s = double(frame.t_ns - *start_ns_ - paused_ns_) * 1e-9;

    // Speed and the blur it would give this frame.
    if (previous_t_ns_ && frame.t_ns > *previous_t_ns_) {
        const double dt = double(frame.t_ns - *previous_t_ns_) * 1e-9;
        const double speed = angle_between(previous_q_, q) / dt;  // rad/s
        s.angular_speed_deg_s = speed * 180.0 / kPi;
        s.blur_px = speed * frame.exposure_s * std::max(camera_.fx, camera_.fy);
        s.too_fast = s.blur_px > settings_.max_blur_px;
    }
    previous_t_ns_ = frame.t_ns;
    previous_q_ = q;

    // Exposure from the frame's codes.
    long long clipped = 0;
    double sum = 0;
    const long long pixels = (long long)frame.rgb.rows * frame.rgb.cols;
    for (int v = 0; v < frame.rgb.rows; ++v) {
        const std::uint8_t* row = frame.rgb.ptr<std::uint8_t>(v);
        for (int u = 0; u < frame.rgb.cols; ++u) {
            const std::uint8_t* p = row + 3 * u;
            clipped += (p[0] == 255 || p[1] == 255 || p[2] == 255) ? 1 : 0;
            sum += (double(p[0]) + double(p[1]) + double(p[2])) / 3;
        }
    }
    s.clipped_share = pixels > 0 ? double(clipped) / double(pixels) : 0;
    s.mean_code = pixels > 0 ? sum / double(pixels) : 0;
    s.exposure = s.clipped_share > settings_.max_clipped_share ? ExposureStatus::TooBright
                 : s.mean_code < settings_.min_mean_code     ? ExposureStatus::TooDark
                                                             : ExposureStatus::Ok;

    // Coverage of what can be seen: the floor cap counts as covered so it is never the target.
    const double floor_theta = (90.0 - settings_.floor_elevation_deg) * kPi / 180.0;  // polar angle
    std::vector<std::uint32_t> seeable = samples;
    double floor_sr = 0;
    for (int j = 0; j < h; ++j) {
        if (row_theta(j, h) <= floor_theta) continue;
        floor_sr += row_solid_angle(j, w, h) * w;
        for (int i = 0; i < w; ++i) seeable[std::size_t(j) * std::size_t(w) + std::size_t(i)] = std::uint32_t(settings_.min_samples);
    }
    const CoverageReport c = measure_coverage(seeable, w, h, settings_.min_samples);
    const double seeable_sr = 4 * kPi - floor_sr;
    s.seeable_coverage = std::clamp((c.covered_fraction * 4 * kPi - floor_sr) / seeable_sr, 0.0, 1.0);
    s.progress = std::min(1.0, s.seeable_coverage / settings_.target_coverage);
    s.next_target = c.largest_gap;
    const double d = glm::dot(q * glm::dvec3(0, 0, -1), s.next_target);
    s.turn_to_target_deg = std::acos(std::clamp(d, -1.0, 1.0)) * 180.0 / kPi;

    if (s.seeable_coverage >= settings_.target_coverage)
        s.state = GuidedState::Complete;
    else if (s.elapsed_s >= settings_.time_limit_s)
        s.state = GuidedState::TimedOut;
    last_ = s;
    return s;
}

void GuidedCapture::frame_unplaced(std::int64_t t_ns) {
    if (start_ns_ && !paused_from_ns_ && t_ns > *start_ns_) paused_from_ns_ = t_ns;
}

}  // namespace glint::capture
