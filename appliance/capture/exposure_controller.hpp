// ExposureController: decides each frame's exposure request in the capture pipeline. Fed every
// frame the camera delivers (with its real exposure and gain metadata), it says what to ask the
// camera next through CameraSource::set_exposure, or nothing (docs/capture.md "Exposure control"):
// - preview: automatic exposure (the camera's own loop) for the viewfinder and the scan;
// - bracketing: after a frame with a clipped pixel, frames at 1/64, 1/4096, ... of that frame's
//   exposure x analogue gain (at gain 1), until one clips nowhere, the shortest exposure still clips, or
//   four were taken; then (unless top_up_below is 0) if that last frame's brightest
//   pixel is under an eighth of the top code's exposure (what clipped before is read in a few
//   codes, in the noise) and belongs to a compact feature, one top-up frame exposed towards half
//   of it but at least a band (kBandStops) below the step that clipped: with steps of 64, 4x the
//   last step; then back to automatic exposure.
//
// A real camera applies a control a few frames late (libcamera pipelines: 2-3 frames) and may
// drop frames, so a bracket frame is recognised by its metadata (exposure x gain within a
// tolerance of what was asked), never by counting frames since the request. A camera that does
// not deliver what was asked within `max_wait_frames` frames times out, and the status says so.
// Frames that are not the one waited for (the pipeline's frames still on the old exposure) are
// left to the caller to use like any other; the controller only does not act on them.
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <string>

#include <opencv2/core.hpp>

#include "appliance/capture/camera_frame.hpp"
#include "appliance/capture/camera_source.hpp"

namespace glint::capture {

struct ExposureControlSettings {
    // Each bracket frame is 1/step_factor of the previous (of the clipped frame for the first):
    // 6 stops, less than the 8 bits' useful range (code 255 down to the read noise), so that what
    // clipped in one frame is well exposed in the next and the frames overlap in what they measure.
    double step_factor = 64;
    // At most this many bracket frames per clipped frame: 64^4 = 2^24 below it, from a 1/120 s
    // preview down to 0.5 ns. A real sensor's shortest exposure (tens of us) ends a bracket after
    // two; the limit bounds a camera without one (the simulator without --sensor-limits) and the
    // scan time and throughput a bracket costs.
    int max_steps = 4;
    // A pixel is clipped when any channel is at this code. 255: the response's top code, where the
    // radiance is unknown (the accumulator drops such pixels, hdr_accumulator.hpp).
    int clip_code = 255;
    // A frame clips when at least this many pixels are clipped. 1: a source of 1e-4 sr is about 7
    // pixels of 320x180, and the share threshold used until 2026-12-02 (2 %) never bracketed it.
    long long min_clipped_pixels = 1;
    // The sensor's shortest exposure time, seconds: CameraCalibration::min_exposure_s (or what the
    // source reports). Requests are never shorter (the camera would clamp, and its frame would not
    // match the request), and a bracket frame at it that still clips ends the bracket: nothing
    // shorter can be asked for. 0 = unknown, no limit.
    double min_exposure_s = 0;
    // Analogue gain of the bracket frames. 1: the lowest noise per unit of exposure x gain, and the
    // brackets only ever shorten the exposure.
    double bracket_gain = 1;
    // A frame is the bracket frame asked for when its exposure x analogue gain is within a factor
    // (1 + match_tolerance) of the request's. Real sensors round the exposure to whole lines
    // (around 10-30 us) and the gain to register steps, so an exact match would miss; the brackets
    // are a factor 64 apart and the frames in between stay near the preview's exposure, so a
    // quarter is far too narrow to take one for another.
    double match_tolerance = 0.25;
    // Frames to wait for a requested exposure before giving up (timeout): libcamera applies a
    // control 2-3 frames late, and a frame or two may be dropped on the way.
    int max_wait_frames = 8;
    // Top-up frame: a bracket whose last frame clips nowhere but whose brightest pixel (brightest
    // channel, as linear exposure) is under top_up_below of the clip code's gets one more frame, at
    // the exposure that puts that pixel at top_up_target of it. Steps of 64 leave what clipped one
    // step before at 1/64 to 1 of the range in the next: a small source at the low end is read in
    // 2-5 codes, where read noise and quantisation scattered its energy by 15-50 % a frame and the
    // 6-15 such frames of a scan left it 2-6 % off (2026-12-05, docs/capture.md "Top-up frames").
    // The top-up's exposure lies between the last two frames' (at least a band's width,
    // kBandStops, below the frame that clipped, so that it never shares that frame's band), and it
    // ends the bracket whatever it shows. With four-stop bands and steps of 64 that cap always
    // binds (under 1/8 of the range, half of it is over 4x away): the top-up is 4x the last step,
    // unless the shortest exposure raised the last step (then no top-up under a factor of
    // (1 + match_tolerance)^2 over it). The band separation holds for frames delivered as asked;
    // one delivered up to match_tolerance long can land in the clipped step's band.
    // top_up_below 0: no top-up frames. On by default since 2026-12-05: kept only two stops
    // below the clipped frame, a top-up shared its band and dim_1e+06 lost 18.7 % of a source; a
    // band below, the stress set and the three maps had 163 of 172 sources within 2 % against
    // 157 without top-ups, studio's irradiance 0.25 % against 0.31 (docs/capture.md "Exposure control").
    double top_up_below = 1.0 / 8;
    double top_up_target = 0.5;
    // Only for a compact bright feature: at most this share of the frame's pixels read over half
    // the brightest one's exposure. A wide bright area (a sky) is read in many pixels whose noise
    // averages out already, and top-ups there cost courtyard's scan registration (0.09 -> 0.18-0.25
    // degrees after 60 s) for nothing. 64 pixels of 320x180 (over 70 degrees: about 1e-3 sr); a
    // share, so that the rule is the same at any stream size over the same field of view.
    double top_up_max_share = 64.0 / (320.0 * 180.0);
    // Linear exposure of each 8-bit code (CameraResponse::inverse of the camera's calibration);
    // only its ratios are used. The default is a linear response.
    std::array<double, 256> code_exposure = linear_codes();

    static std::array<double, 256> linear_codes() {
        std::array<double, 256> a{};
        for (int z = 0; z < 256; ++z) a[std::size_t(z)] = (z + 0.5) / 256.0;
        return a;
    }
};

enum class ExposureControlState : std::uint8_t { Preview, Bracketing };

// How the last bracket ended (None before the first).
enum class BracketOutcome : std::uint8_t {
    None,
    Unclipped,             // its last step clipped nowhere (a top-up after it may have: top_ups_clipped)
    ClippedAtShortest,     // still clipped at the shortest exposure (min_exposure_s)
    ClippedAfterAllSteps,  // still clipped after max_steps frames
    TimedOut,              // the camera did not deliver the requested exposure (a top-up's too) within max_wait_frames
    NotResumed,            // after it, the camera stayed on the bracket's exposure for max_wait_frames
};

const char* exposure_control_state_name(ExposureControlState s);
const char* bracket_outcome_name(BracketOutcome o);

// What the UI can show.
struct ExposureControlStatus {
    ExposureControlState state = ExposureControlState::Preview;
    int step = 0;           // bracketing: the bracket frame waited for, 1..steps
    int steps = 0;          // bracketing: at most this many (ExposureControlSettings::max_steps)
    bool top_up = false;    // bracketing: the frame waited for is the bracket's top-up
    double asked_exposure_s = 0, asked_gain = 1;  // bracketing: the request waited for
    int waited_frames = 0;  // bracketing: frames delivered since that request that were not it
    BracketOutcome last = BracketOutcome::None;
    // "preview", "bracketing 2 of 4", "preview; clipped at the shortest exposure (2e-05 s)",
    // "preview; timed out: the camera did not deliver 2.03e-06 s at gain 1 within 8 frames", ...
    std::string text() const;
};

struct ExposureControlCounters {
    std::uint64_t frames = 0;          // fed
    std::uint64_t clipped_frames = 0;  // judged clipped (previews that started a bracket, clipped bracket frames)
    std::uint64_t brackets = 0;        // started
    std::uint64_t bracket_frames = 0;  // delivered frames recognised as the bracket frame asked for (top-ups too)
    std::uint64_t top_ups = 0;         // top-up frames asked for
    std::uint64_t top_ups_clipped = 0; // top-up frames delivered with a clipped pixel (the bracket still ends unclipped)
    std::uint64_t waited_frames = 0;   // frames not acted on: not the one waited for, or a bracket's leftovers
    std::uint64_t requests = 0;        // requests returned (manual and automatic)
    // How brackets ended (the four add up to brackets, less one still running). A clipped frame
    // already at the shortest exposure counts as a bracket clipped at the shortest, of no frames.
    std::uint64_t unclipped = 0, clipped_at_shortest = 0, clipped_after_all_steps = 0;
    std::uint64_t timeouts = 0;     // TimedOut: the camera did not deliver a requested exposure
    std::uint64_t not_resumed = 0;  // NotResumed: it stayed on a bracket's exposure after it
};

class ExposureController {
public:
    // Throws InputError naming the setting at fault. Assumes the camera starts on automatic exposure.
    explicit ExposureController(ExposureControlSettings settings = {});

    // One delivered frame, in delivery order. Returns the request to send to the camera now
    // (CameraSource::set_exposure), or nullopt: no change.
    std::optional<ExposureRequest> on_frame(const CameraFrame& frame);

    bool bracketing() const { return status_.state == ExposureControlState::Bracketing; }
    const ExposureControlStatus& status() const { return status_; }
    const ExposureControlCounters& counters() const { return counters_; }
    const ExposureControlSettings& settings() const { return settings_; }

    // Pixels of an 8-bit RGB frame with a channel at `clip_code` or above, counting up to `stop_at`.
    static long long clipped_pixels(const cv::Mat& rgb, int clip_code, long long stop_at);

private:
    bool clipped(const CameraFrame& frame) const;
    bool matches(const CameraFrame& frame, double exposure_s, double gain) const;
    ExposureRequest bracket_request(int step) const;
    // The top-up after `frame` (an unclipped bracket frame), or nothing when it is exposed well.
    std::optional<ExposureRequest> top_up_request(const CameraFrame& frame) const;
    ExposureRequest finish(BracketOutcome outcome);
    ExposureRequest automatic();

    ExposureControlSettings settings_;
    ExposureControlStatus status_;
    ExposureControlCounters counters_;
    double parent_exposure_gain_ = 0;  // exposure x analogue gain of the frame that started the bracket
    // After a bracket: the last manual request, whose frames may still come while the camera
    // returns to automatic exposure. They are not a new view to bracket.
    std::optional<ExposureRequest> leftover_;
    int leftover_frames_ = 0;
};

}  // namespace glint::capture
