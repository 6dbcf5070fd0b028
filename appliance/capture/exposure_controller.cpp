#include "appliance/capture/exposure_controller.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>

#include "appliance/capture/exposure_bands.hpp"
#include "appliance/core/errors.hpp"

namespace glint::capture {

const char* exposure_control_state_name(ExposureControlState s) {
    switch (s) {
        case ExposureControlState::Preview: return "preview";
        case ExposureControlState::Bracketing: return "bracketing";
    }
    return "unknown";
}

const char* bracket_outcome_name(BracketOutcome o) {
    switch (o) {
        case BracketOutcome::None: return "none";
        case BracketOutcome::Unclipped: return "unclipped";
        case BracketOutcome::ClippedAtShortest: return "clipped at the shortest exposure";
        case BracketOutcome::ClippedAfterAllSteps: return "still clipped after all brackets";
        case BracketOutcome::TimedOut: return "timed out";
        case BracketOutcome::NotResumed: return "automatic exposure not resumed";
    }
    return "unknown";
}

std::string ExposureControlStatus::text() const {
    char s[160];
    if (state == ExposureControlState::Bracketing) {
        const char* what = top_up ? ", top-up" : "";
        if (waited_frames == 0)
            std::snprintf(s, sizeof s, "bracketing %d of %d%s", step, steps, what);
        else
            std::snprintf(s, sizeof s, "bracketing %d of %d%s (waiting %d frames for %.3g s at gain %.3g)", step, steps,
                          what, waited_frames, asked_exposure_s, asked_gain);
        return s;
    }
    switch (last) {
        case BracketOutcome::None:
        case BracketOutcome::Unclipped: return "preview";
        case BracketOutcome::ClippedAtShortest:
            std::snprintf(s, sizeof s, "preview; clipped at the shortest exposure (%.3g s)", asked_exposure_s);
            return s;
        case BracketOutcome::ClippedAfterAllSteps:
            std::snprintf(s, sizeof s, "preview; still clipped after %d brackets", steps);
            return s;
        case BracketOutcome::TimedOut:
            std::snprintf(s, sizeof s, "preview; timed out: the camera did not deliver %.3g s at gain %.3g within %d frames",
                          asked_exposure_s, asked_gain, waited_frames);
            return s;
        case BracketOutcome::NotResumed:
            std::snprintf(s, sizeof s,
                          "preview; timed out: the camera stayed on %.3g s at gain %.3g for %d frames after the bracket "
                          "(automatic exposure not resumed)",
                          asked_exposure_s, asked_gain, waited_frames);
            return s;
    }
    return "preview";
}

ExposureController::ExposureController(ExposureControlSettings settings) : settings_(settings) {
    const ExposureControlSettings& p = settings_;
    if (!(p.step_factor > 1)) throw InputError("exposure control: step_factor must be greater than 1");
    if (p.max_steps < 1) throw InputError("exposure control: max_steps must be at least 1");
    if (p.clip_code < 1 || p.clip_code > 255) throw InputError("exposure control: clip_code must be 1..255");
    if (p.min_clipped_pixels < 1) throw InputError("exposure control: min_clipped_pixels must be at least 1");
    if (!(p.min_exposure_s >= 0)) throw InputError("exposure control: min_exposure_s must be 0 (unknown) or positive");
    if (!(p.bracket_gain >= 1)) throw InputError("exposure control: bracket_gain must be at least 1");
    // Two neighbouring brackets must never both match one frame.
    if (!(p.match_tolerance > 0) || !((1 + p.match_tolerance) * (1 + p.match_tolerance) < p.step_factor))
        throw InputError("exposure control: match_tolerance must be positive and (1 + it)^2 below step_factor");
    if (p.max_wait_frames < 1) throw InputError("exposure control: max_wait_frames must be at least 1");
    if (!(p.top_up_max_share > 0) || !(p.top_up_max_share <= 1))
        throw InputError("exposure control: top_up_max_share must be in (0, 1]");
    if (!(p.top_up_below >= 0) || !(p.top_up_below < p.top_up_target) || !(p.top_up_target < 1))
        throw InputError("exposure control: need 0 <= top_up_below < top_up_target < 1");
    for (int z = 1; z < 256; ++z)
        if (!(p.code_exposure[std::size_t(z)] > p.code_exposure[std::size_t(z - 1)]) || !(p.code_exposure[0] >= 0))
            throw InputError("exposure control: code_exposure must be non-negative and strictly increasing");
    status_.steps = p.max_steps;
}

long long ExposureController::clipped_pixels(const cv::Mat& rgb, int clip_code, long long stop_at) {
    if (rgb.empty()) return 0;
    if (rgb.type() != CV_8UC3) throw InputError("exposure control: frames must be 8-bit RGB");
    long long n = 0;
    for (int v = 0; v < rgb.rows; ++v) {
        const std::uint8_t* row = rgb.ptr<std::uint8_t>(v);
        for (int u = 0; u < rgb.cols; ++u) {
            const std::uint8_t* p = row + 3 * u;
            n += (p[0] >= clip_code || p[1] >= clip_code || p[2] >= clip_code) ? 1 : 0;
        }
        if (n >= stop_at) return n;  // whole rows: cheap, and the rule only needs "at least"
    }
    return n;
}

bool ExposureController::clipped(const CameraFrame& frame) const {
    return clipped_pixels(frame.rgb, settings_.clip_code, settings_.min_clipped_pixels) >= settings_.min_clipped_pixels;
}

bool ExposureController::matches(const CameraFrame& frame, double exposure_s, double gain) const {
    // ExposureTime x AnalogueGain: what the request set. The ISP's digital gain is not requested.
    const double got = frame.exposure_s * frame.analogue_gain, asked = exposure_s * gain;
    if (!(got > 0) || !(asked > 0)) return false;
    return std::abs(std::log(got / asked)) <= std::log1p(settings_.match_tolerance);
}

ExposureRequest ExposureController::bracket_request(int step) const {
    // Of the clipped frame's exposure x gain, at the bracket gain; never below the shortest
    // exposure, which the camera would clamp to anyway (and its frame would then not match).
    const double want = parent_exposure_gain_ * std::pow(settings_.step_factor, -step);
    ExposureRequest r;
    r.automatic = false;
    r.exposure_s = std::max(want / settings_.bracket_gain, settings_.min_exposure_s);
    r.analogue_gain = settings_.bracket_gain;
    return r;
}

std::optional<ExposureRequest> ExposureController::top_up_request(const CameraFrame& frame) const {
    const ExposureControlSettings& p = settings_;
    if (!(p.top_up_below > 0) || frame.rgb.empty()) return std::nullopt;
    // One pass: how many pixels have each brightest-channel code.
    std::array<long long, 256> pixels_at{};
    for (int v = 0; v < frame.rgb.rows; ++v) {
        const std::uint8_t* row = frame.rgb.ptr<std::uint8_t>(v);
        for (int u = 0; u < frame.rgb.cols; ++u) {
            const std::uint8_t* px = row + 3 * u;
            ++pixels_at[std::max({px[0], px[1], px[2]})];
        }
    }
    int z_max = 255;
    while (z_max > 0 && pixels_at[std::size_t(z_max)] == 0) --z_max;
    // As a share of the top unclipped code's exposure (the frame clips nowhere: z_max < clip_code).
    const double top = p.code_exposure[std::size_t(p.clip_code - 1)];
    const double share = p.code_exposure[std::size_t(z_max)] / top;
    if (!(share < p.top_up_below) || !(share > 0)) return std::nullopt;
    // A compact feature only: few pixels over half the brightest one's exposure.
    const double half = 0.5 * p.code_exposure[std::size_t(z_max)];
    const long long max_pixels =
        std::max(1LL, (long long)std::floor(p.top_up_max_share * double(frame.rgb.rows) * double(frame.rgb.cols)));
    long long bright = 0;
    for (int z = z_max; z >= 0 && p.code_exposure[std::size_t(z)] >= half; --z) bright += pixels_at[std::size_t(z)];
    if (bright > max_pixels) return std::nullopt;
    // At least a band's width (exposure_bands.hpp) below the frame that clipped one step before
    // (the parent for step 1), so that the two never share a band: there the clipped frame's
    // misregistered reads beside a source would outweigh the top-up's. Measured from the clipped
    // frame's requested exposure x gain, not from this frame's, which the shortest exposure may
    // have raised.
    const double got = frame.exposure_s * frame.analogue_gain;
    const double clipped_exposure_gain = parent_exposure_gain_ * std::pow(p.step_factor, -(status_.step - 1));
    const double factor = std::min(p.top_up_target / share, clipped_exposure_gain / std::exp2(kBandStops) / got);
    if (!(factor > (1 + p.match_tolerance) * (1 + p.match_tolerance))) return std::nullopt;
    // Exposure x analogue gain, what a request sets and matches() compares: the ISP's digital
    // gain, which it applies again to the top-up, stays out.
    const double want = got * factor;
    ExposureRequest r;
    r.automatic = false;
    r.exposure_s = std::max(want / p.bracket_gain, p.min_exposure_s);
    r.analogue_gain = p.bracket_gain;
    return r;
}

ExposureRequest ExposureController::automatic() {
    ++counters_.requests;
    ExposureRequest r;
    r.automatic = true;
    return r;
}

ExposureRequest ExposureController::finish(BracketOutcome outcome) {
    switch (outcome) {
        case BracketOutcome::Unclipped: ++counters_.unclipped; break;
        case BracketOutcome::ClippedAtShortest: ++counters_.clipped_at_shortest; break;
        case BracketOutcome::ClippedAfterAllSteps: ++counters_.clipped_after_all_steps; break;
        case BracketOutcome::TimedOut: ++counters_.timeouts; break;
        case BracketOutcome::NotResumed: ++counters_.not_resumed; break;
        case BracketOutcome::None: break;
    }
    status_.state = ExposureControlState::Preview;
    status_.top_up = false;
    status_.last = outcome;
    // Whatever the camera still delivers on the last manual request is not a new view.
    ExposureRequest last;
    last.automatic = false;
    last.exposure_s = status_.asked_exposure_s;
    last.analogue_gain = status_.asked_gain;
    leftover_ = last;
    leftover_frames_ = 0;
    return automatic();
}

std::optional<ExposureRequest> ExposureController::on_frame(const CameraFrame& frame) {
    ++counters_.frames;
    const ExposureControlSettings& p = settings_;

    if (status_.state == ExposureControlState::Bracketing) {
        if (!matches(frame, status_.asked_exposure_s, status_.asked_gain)) {
            // Not yet applied (or a frame was dropped): wait, up to max_wait_frames.
            ++counters_.waited_frames;
            if (++status_.waited_frames >= p.max_wait_frames) return finish(BracketOutcome::TimedOut);
            return std::nullopt;
        }
        ++counters_.bracket_frames;
        // The top-up ends the bracket whatever it shows: the bracket's last step clipped nowhere,
        // and the accumulator drops whatever the top-up clipped (counted apart).
        if (status_.top_up) {
            if (clipped(frame)) ++counters_.top_ups_clipped;
            return finish(BracketOutcome::Unclipped);
        }
        if (!clipped(frame)) {
            const std::optional<ExposureRequest> top_up = top_up_request(frame);
            if (!top_up) return finish(BracketOutcome::Unclipped);
            status_.top_up = true;
            status_.asked_exposure_s = top_up->exposure_s;
            status_.asked_gain = top_up->analogue_gain;
            status_.waited_frames = 0;
            ++counters_.top_ups;
            ++counters_.requests;
            return top_up;
        }
        ++counters_.clipped_frames;
        // Asked at the shortest exposure (the request was clamped to it) and still clipped.
        if (p.min_exposure_s > 0 && status_.asked_exposure_s <= p.min_exposure_s)
            return finish(BracketOutcome::ClippedAtShortest);
        if (status_.step >= p.max_steps) return finish(BracketOutcome::ClippedAfterAllSteps);
        const ExposureRequest next = bracket_request(++status_.step);
        status_.asked_exposure_s = next.exposure_s;
        status_.asked_gain = next.analogue_gain;
        status_.waited_frames = 0;
        ++counters_.requests;
        return next;
    }

    // Preview. The frames of the last bracket's request that the camera still delivers while it
    // returns to automatic exposure are skipped: bracketing them again would repeat that bracket.
    if (leftover_) {
        if (matches(frame, leftover_->exposure_s, leftover_->analogue_gain)) {
            ++counters_.waited_frames;
            if (++leftover_frames_ < p.max_wait_frames) return std::nullopt;
            // The camera ignored the return to automatic exposure: say so, ask again, and from now
            // on treat its frames as views.
            status_.waited_frames = leftover_frames_;
            status_.last = BracketOutcome::NotResumed;
            ++counters_.not_resumed;
            leftover_.reset();
            return automatic();
        }
        leftover_.reset();
    }
    if (!clipped(frame)) return std::nullopt;
    ++counters_.clipped_frames;
    ++counters_.brackets;
    // Exposure x analogue gain, as requests set and matches() compares: the ISP applies its digital
    // gain to the bracket frames too, so counting it here would make the first step d/64, not 1/64.
    parent_exposure_gain_ = frame.exposure_s * frame.analogue_gain;
    status_.steps = p.max_steps;
    status_.waited_frames = 0;
    // Already at the shortest exposure (and the bracket gain): nothing shorter to ask for.
    if (p.min_exposure_s > 0 &&
        parent_exposure_gain_ <= p.min_exposure_s * p.bracket_gain * (1 + p.match_tolerance)) {
        ++counters_.clipped_at_shortest;
        status_.last = BracketOutcome::ClippedAtShortest;
        status_.asked_exposure_s = frame.exposure_s;
        status_.asked_gain = frame.analogue_gain;
        return std::nullopt;
    }
    status_.state = ExposureControlState::Bracketing;
    status_.step = 1;
    const ExposureRequest first = bracket_request(1);
    status_.asked_exposure_s = first.exposure_s;
    status_.asked_gain = first.analogue_gain;
    ++counters_.requests;
    return first;
}

}  // namespace glint::capture
