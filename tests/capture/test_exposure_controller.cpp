#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <deque>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "appliance/capture/exposure_bands.hpp"
#include "appliance/capture/exposure_controller.hpp"
#include "appliance/core/equirect.hpp"
#include "appliance/core/errors.hpp"
#include "appliance/sim/camera_simulator.hpp"
#include "appliance/sim/session_simulator.hpp"
#include "firmware_bridge/host/clock.hpp"

namespace glint::capture {
namespace {

// A camera of 8x8 pixels: a background at code 100 and one source pixel of `source` times the
// code of exposure x gain 1/255 (so at exposure x gain E it clips when source x E >= 1). Its own
// auto-exposure wanders round 10 ms (as a real loop does) and clips the source. A request applies
// `delay` frames after the next one (0: from the next frame), as libcamera's pipelines do.
class FakeCamera {
public:
    FakeCamera(int delay, double source, double min_exposure_s = 0)
        : delay_(delay), source_(source), min_exposure_s_(min_exposure_s) {}

    void set_exposure(const ExposureRequest& r) {
        if (ignore_requests || (ignore_automatic && r.automatic)) return;
        pending_.push_back({delivered_ + delay_, r});
    }

    CameraFrame next_frame() {
        while (!pending_.empty() && pending_.front().first <= delivered_) {
            state_ = pending_.front().second;
            pending_.pop_front();
        }
        CameraFrame f;
        f.sequence = std::uint64_t(delivered_);
        f.t_ns = delivered_ * 33'000'000;
        if (state_.automatic) {
            f.exposure_s = 0.01 * (1 + 0.03 * double(delivered_ % 3));  // the loop never sits still
            f.analogue_gain = 1;
        } else {
            f.exposure_s = std::max(state_.exposure_s, min_exposure_s_);
            f.analogue_gain = state_.analogue_gain;
        }
        f.digital_gain = digital_gain;
        f.rgb = cv::Mat(8, 8, CV_8UC3, cv::Scalar(background, background, background));
        const double code = 255 * source_ * f.exposure_s * f.analogue_gain * f.digital_gain;
        if (source_in_view) {
            const auto c = std::uint8_t(std::min(255.0, std::round(code)));
            f.rgb.at<cv::Vec3b>(3, 4) = {c, std::uint8_t(c / 2), 10};  // clipped in one channel is enough
        }
        ++delivered_;
        return f;
    }

    bool ignore_requests = false;
    bool ignore_automatic = false;  // stays on the last manual request
    bool source_in_view = true;
    int background = 100;  // code of every other pixel, whatever the exposure
    double digital_gain = 1;  // the ISP's, on every frame (automatic or not), as a real pipeline may

private:
    int delay_;
    double source_, min_exposure_s_;
    long long delivered_ = 0;
    ExposureRequest state_;  // automatic
    std::deque<std::pair<long long, ExposureRequest>> pending_;
};

struct Step {
    double exposure_gain;  // of the frame fed
    bool clipped;
    std::optional<ExposureRequest> request;  // what the controller said after it
    ExposureControlState state;
};

std::vector<Step> run(ExposureController& controller, FakeCamera& cam, int frames) {
    std::vector<Step> out;
    for (int k = 0; k < frames; ++k) {
        const CameraFrame f = cam.next_frame();
        const auto r = controller.on_frame(f);
        if (r) cam.set_exposure(*r);
        out.push_back({f.exposure_s * f.analogue_gain, ExposureController::clipped_pixels(f.rgb, 255, 1) > 0, r,
                       controller.status().state});
    }
    return out;
}

// Indices of the frames after which a request was made.
std::vector<int> request_frames(const std::vector<Step>& steps) {
    std::vector<int> out;
    for (std::size_t k = 0; k < steps.size(); ++k)
        if (steps[k].request) out.push_back(int(k));
    return out;
}

TEST(ExposureController, BracketsAtOneSixtyFourthStepsUntilNothingClipsThenBackToPreview) {
    // The source clips at 10 ms and at 1/64 of it, not at 1/4096.
    FakeCamera cam(0, 1e5);
    ExposureController controller;
    EXPECT_EQ(controller.status().text(), "preview");
    const std::vector<Step> s = run(controller, cam, 4);
    // Frame 0 clips: 1/64 of its exposure x gain at gain 1.
    ASSERT_TRUE(s[0].request);
    EXPECT_FALSE(s[0].request->automatic);
    EXPECT_DOUBLE_EQ(s[0].request->exposure_s, s[0].exposure_gain / 64);
    EXPECT_EQ(s[0].request->analogue_gain, 1.0);
    EXPECT_EQ(s[0].state, ExposureControlState::Bracketing);
    // Frame 1 is that bracket and still clips: 1/4096 of frame 0 (not of frame 1).
    EXPECT_DOUBLE_EQ(s[1].exposure_gain, s[0].exposure_gain / 64);
    EXPECT_TRUE(s[1].clipped);
    ASSERT_TRUE(s[1].request);
    EXPECT_DOUBLE_EQ(s[1].request->exposure_s, s[0].exposure_gain / 4096);
    // Frame 2 clips nowhere: back to automatic exposure, and preview.
    EXPECT_FALSE(s[2].clipped);
    ASSERT_TRUE(s[2].request);
    EXPECT_TRUE(s[2].request->automatic);
    EXPECT_EQ(s[2].state, ExposureControlState::Preview);
    EXPECT_EQ(controller.status().last, BracketOutcome::Unclipped);
    // Frame 3 is automatic again and clips: a new bracket.
    EXPECT_TRUE(s[3].request && !s[3].request->automatic);
    const ExposureControlCounters& c = controller.counters();
    EXPECT_EQ(c.frames, 4u);
    EXPECT_EQ(c.brackets, 2u);
    EXPECT_EQ(c.bracket_frames, 2u);
    EXPECT_EQ(c.unclipped, 1u);
    EXPECT_EQ(c.timeouts, 0u);
    EXPECT_EQ(controller.status().text(), "bracketing 1 of 4");
}

// Top-up frames below an eighth of the range (the default since 2026-12-05; exposure_controller.hpp).
ExposureControlSettings top_ups_on() {
    ExposureControlSettings s;
    s.top_up_below = 1.0 / 8;
    return s;
}

TEST(ExposureController, ABracketWhoseLastFrameReadsTheSourceInAFewCodesTakesATopUpFrame) {
    for (int delay : {0, 3}) {
        SCOPED_TRACE(delay);
        // The source clips at ~10 ms and at 1/64 of it; at 1/4096 it reads ~12 codes of 255 (under
        // an eighth): one top-up frame towards half the range but a band below the 1/64 step (4x
        // the last step, ~50 codes), then preview.
        FakeCamera cam(delay, 2e4);
        cam.background = 2;  // a dark room: the source is the brightest pixel of the short frames
        ExposureController controller(top_ups_on());
        const std::vector<Step> s = run(controller, cam, 1 + 3 * (delay + 1));
        const std::vector<int> asked = request_frames(s);
        ASSERT_EQ(asked.size(), 4u);
        const Step& last_step = s[std::size_t(asked[2])];  // the 1/4096 frame, unclipped
        EXPECT_DOUBLE_EQ(last_step.exposure_gain, s[0].exposure_gain / 4096);
        EXPECT_FALSE(last_step.clipped);
        ASSERT_TRUE(last_step.request && !last_step.request->automatic);
        const double code = std::round(255 * 2e4 * last_step.exposure_gain);
        // Its share of the top unclipped code (254) as exposure, on the default linear response:
        // the exposure that puts it at half the range, capped at a band's width (kBandStops) below
        // the step that clipped (s[0] / 64), so that the top-up never shares that step's band.
        const double half_range = last_step.exposure_gain * 0.5 / ((code + 0.5) / 254.5);
        const double band_below = s[0].exposure_gain / 64 / std::exp2(kBandStops);
        EXPECT_NEAR(last_step.request->exposure_s, std::min(half_range, band_below), 1e-12);
        EXPECT_GT(last_step.request->exposure_s, last_step.exposure_gain * 2);
        EXPECT_LT(exposure_band(last_step.request->exposure_s), exposure_band(s[0].exposure_gain / 64));
        // The top-up frame: the source read in several times the codes of the 1/4096 frame (under
        // half the range), and the bracket ends with it.
        const Step& top_up = s[std::size_t(asked[3])];
        EXPECT_DOUBLE_EQ(top_up.exposure_gain, last_step.request->exposure_s);
        EXPECT_FALSE(top_up.clipped);
        EXPECT_NEAR(255 * 2e4 * top_up.exposure_gain, 255 * 2e4 * std::min(half_range, band_below), 1e-9);
        EXPECT_GE(255 * 2e4 * top_up.exposure_gain, 3 * code);
        EXPECT_LE(255 * 2e4 * top_up.exposure_gain, 128 + 12);
        ASSERT_TRUE(top_up.request);
        EXPECT_TRUE(top_up.request->automatic);
        EXPECT_EQ(top_up.state, ExposureControlState::Preview);
        EXPECT_EQ(controller.counters().top_ups, 1u);
        EXPECT_EQ(controller.counters().bracket_frames, 3u);
        EXPECT_EQ(controller.status().last, BracketOutcome::Unclipped);
    }
    // Off (top_up_below 0): the bracket ends at the unclipped frame.
    EXPECT_EQ(ExposureControlSettings{}.top_up_below, 1.0 / 8);  // on by default
    FakeCamera cam(0, 2e4);
    cam.background = 2;
    ExposureControlSettings off;
    off.top_up_below = 0;
    ExposureController controller(off);
    const std::vector<Step> s = run(controller, cam, 3);
    ASSERT_TRUE(s[2].request);
    EXPECT_TRUE(s[2].request->automatic);
    EXPECT_EQ(controller.counters().top_ups, 0u);
}

TEST(ExposureController, TheFirstStepIsASixtyFourthOfTheClippedFrameWhateverTheDigitalGain) {
    // The ISP applies its digital gain to the bracket frames too: the step is of exposure x
    // analogue gain, and the bracket frame reads the source at 1/64 of what the clipped frame
    // would have read (before 2026-12-05 the total gain made it 1.5/64 here).
    FakeCamera cam(0, 1e3);  // at ~10 ms: 2550 codes (clipped); at 1/64: ~40 codes x 1.5
    cam.digital_gain = 1.5;
    cam.background = 2;
    ExposureController controller;
    const std::vector<Step> s = run(controller, cam, 2);
    ASSERT_TRUE(s[0].request);
    EXPECT_DOUBLE_EQ(s[0].request->exposure_s, s[0].exposure_gain / 64);
    EXPECT_EQ(s[0].request->analogue_gain, 1.0);
    EXPECT_DOUBLE_EQ(s[1].exposure_gain, s[0].exposure_gain / 64);  // recognised as the bracket frame
    EXPECT_FALSE(s[1].clipped);
    EXPECT_EQ(controller.counters().bracket_frames, 1u);
    EXPECT_EQ(controller.status().last, BracketOutcome::Unclipped);
}

TEST(ExposureController, ATopUpThatClipsIsCountedAndOneNeverDeliveredTimesOut) {
    // The top-up asked for (the source at ~50 codes), then the source reads 8x brighter (the
    // fake's ISP digital gain, so the frame still matches the request) and it clips.
    {
        FakeCamera cam(0, 2e4);
        cam.background = 2;
        ExposureController controller(top_ups_on());
        run(controller, cam, 3);
        ASSERT_TRUE(controller.status().top_up);
        cam.digital_gain = 8;
        const std::vector<Step> s = run(controller, cam, 1);
        EXPECT_TRUE(s[0].clipped);
        ASSERT_TRUE(s[0].request && s[0].request->automatic);
        EXPECT_EQ(controller.counters().top_ups, 1u);
        EXPECT_EQ(controller.counters().top_ups_clipped, 1u);
        EXPECT_EQ(controller.status().last, BracketOutcome::Unclipped);
    }
    // A camera that stops honouring requests after the bracket's last step: the top-up times out.
    {
        FakeCamera cam(0, 2e4);
        cam.background = 2;
        ExposureController controller(top_ups_on());
        run(controller, cam, 2);
        cam.ignore_requests = true;
        run(controller, cam, 1 + 8);
        EXPECT_EQ(controller.counters().top_ups, 1u);
        EXPECT_EQ(controller.counters().top_ups_clipped, 0u);
        EXPECT_EQ(controller.counters().timeouts, 1u);
        EXPECT_EQ(controller.status().last, BracketOutcome::TimedOut);
        EXPECT_NE(controller.status().text().find("timed out: the camera did not deliver"), std::string::npos)
            << controller.status().text();
    }
}

TEST(ExposureController, ATopUpAfterAStepRaisedToTheShortestExposureStaysABandBelowTheClippedFrame) {
    // The source clips at 10 ms; the first step (1/64: 0.16 ms) is raised to the shortest
    // exposure. At 0.2 ms it reads the source at 8 codes: half the range would be 15x that, 3.0 ms,
    // only 1.7 stops under the clipped frame; the top-up stays a band's width (kBandStops) below
    // the clipped frame's exposure (0.625 ms), in a band below it; so at 0.35 ms (1.79x). At 0.45
    // and 0.5 ms that is 1.39x and 1.25x the raised step, under (1 + match_tolerance)^2 = 1.5625x:
    // no top-up, a frame for nothing.
    for (const auto& [shortest, top_up_expected] :
         {std::pair{2e-4, true}, std::pair{3.5e-4, true}, std::pair{4.5e-4, false}, std::pair{5e-4, false}}) {
        SCOPED_TRACE(shortest);
        FakeCamera cam(0, 150, shortest);
        cam.background = 2;
        ExposureControlSettings settings = top_ups_on();
        settings.min_exposure_s = shortest;
        ExposureController controller(settings);
        const std::vector<Step> s = run(controller, cam, 3);
        ASSERT_TRUE(s[0].clipped);
        EXPECT_DOUBLE_EQ(s[1].exposure_gain, shortest);
        EXPECT_FALSE(s[1].clipped);
        ASSERT_TRUE(s[1].request);
        if (!top_up_expected) {
            EXPECT_TRUE(s[1].request->automatic);
            EXPECT_EQ(controller.counters().top_ups, 0u);
            continue;
        }
        ASSERT_FALSE(s[1].request->automatic);
        const double top_up = s[1].request->exposure_s;
        EXPECT_NEAR(top_up, s[0].exposure_gain / std::exp2(kBandStops), 1e-12);
        EXPECT_LT(exposure_band(top_up), exposure_band(s[0].exposure_gain));
        EXPECT_DOUBLE_EQ(s[2].exposure_gain, top_up);
        EXPECT_EQ(controller.counters().top_ups, 1u);
    }
}

TEST(ExposureController, AWideBrightAreaReadLowGetsNoTopUp) {
    // At 1/4096 the source reads ~12 codes and the whole 8x8 frame 8: every pixel is over half the
    // brightest one's exposure, a wide area (over top_up_max_share of them), whose many pixels average
    // their noise already: the bracket ends there. With a dark room the same source gets one.
    for (const int background : {8, 2}) {
        SCOPED_TRACE(background);
        FakeCamera cam(0, 2e4);
        cam.background = background;
        ExposureControlSettings settings = top_ups_on();
        settings.top_up_max_share = 10.0 / 64;  // 10 of the fake camera's 8x8 pixels
        ExposureController controller(settings);
        const std::vector<Step> s = run(controller, cam, 3);
        ASSERT_TRUE(s[2].request);
        EXPECT_EQ(s[2].request->automatic, background == 8);
        EXPECT_EQ(controller.counters().top_ups, background == 8 ? 0u : 1u);
    }
}

TEST(ExposureController, TheTopUpWaitedForIsInTheStatusText) {
    FakeCamera cam(0, 2e4);
    cam.background = 2;
    ExposureController controller(top_ups_on());
    run(controller, cam, 3);
    EXPECT_EQ(controller.status().text(), "bracketing 2 of 4, top-up");
    EXPECT_THROW(ExposureController([] {
                     ExposureControlSettings bad;
                     bad.top_up_below = 0.6;
                     return bad;
                 }()),
                 InputError);
}

TEST(ExposureController, ABracketFrameIsFoundByItsExposureWhenControlsApplyThreeFramesLate) {
    FakeCamera cam(3, 1e5);
    ExposureController controller;
    const std::vector<Step> s = run(controller, cam, 13);
    // A request after frame j shows from frame j + 4. Requests: after frame 0 (1/64), after frame
    // 4, which shows it (1/4096), after frame 8, which shows that and clips nowhere (automatic).
    // Frames 1-3 (still automatic, and clipped) and 5-7 (still 1/64) are waited through: counting
    // frames would have taken frame 1 for the first bracket.
    EXPECT_EQ(request_frames(s), (std::vector<int>{0, 4, 8, 12}));
    EXPECT_DOUBLE_EQ(s[4].exposure_gain, s[0].exposure_gain / 64);
    EXPECT_DOUBLE_EQ(s[8].exposure_gain, s[0].exposure_gain / 4096);
    EXPECT_DOUBLE_EQ(s[4].request->exposure_s, s[0].exposure_gain / 4096);
    EXPECT_TRUE(s[8].request->automatic);
    for (int k : {1, 2, 3}) EXPECT_TRUE(s[std::size_t(k)].clipped) << k;
    for (int k : {1, 2, 3, 5, 6, 7}) EXPECT_EQ(s[std::size_t(k)].state, ExposureControlState::Bracketing) << k;
    EXPECT_EQ(s[8].state, ExposureControlState::Preview);
    EXPECT_EQ(controller.counters().bracket_frames, 2u);
    // Frames 9-11 are the bracket's leftovers while the camera returns to automatic exposure.
    EXPECT_EQ(controller.counters().waited_frames, 3u + 3u + 3u);
    EXPECT_DOUBLE_EQ(s[11].exposure_gain, s[8].exposure_gain);
    // Frame 12 is automatic and clips: a new bracket, of frame 12.
    EXPECT_NEAR(s[12].exposure_gain, 0.01, 0.001);
    EXPECT_DOUBLE_EQ(s[12].request->exposure_s, s[12].exposure_gain / 64);
    EXPECT_EQ(controller.counters().brackets, 2u);
    EXPECT_EQ(controller.counters().unclipped, 1u);
    EXPECT_EQ(controller.counters().timeouts, 0u);
}

TEST(ExposureController, LeftoverBracketFramesThatClipDoNotStartAnotherBracket) {
    // The source clips even at 1/64^4 of 10 ms: four brackets, all clipped; the camera then stays
    // on the last one for 3 frames (clipped), which must not be bracketed again.
    FakeCamera cam(3, 1e10);
    ExposureController controller;
    const std::vector<Step> s = run(controller, cam, 21);
    EXPECT_EQ(request_frames(s), (std::vector<int>{0, 4, 8, 12, 16, 20}));
    EXPECT_TRUE(s[16].request->automatic);
    EXPECT_TRUE(s[16].clipped);
    for (int k : {17, 18, 19}) {
        EXPECT_TRUE(s[std::size_t(k)].clipped) << k;
        EXPECT_DOUBLE_EQ(s[std::size_t(k)].exposure_gain, s[0].exposure_gain * std::pow(64.0, -4)) << k;
    }
    // Automatic again (frame 20): a new bracket.
    EXPECT_FALSE(s[20].request->automatic);
    EXPECT_EQ(controller.counters().clipped_after_all_steps, 1u);
    EXPECT_EQ(controller.counters().brackets, 2u);
    EXPECT_EQ(controller.counters().bracket_frames, 4u);
}

TEST(ExposureController, StillClippedAfterAllStepsIsTheStatus) {
    FakeCamera cam(0, 1e10);
    ExposureController controller;
    const std::vector<Step> s = run(controller, cam, 5);
    EXPECT_EQ(request_frames(s), (std::vector<int>{0, 1, 2, 3, 4}));
    EXPECT_TRUE(s[4].request->automatic);
    EXPECT_EQ(controller.status().last, BracketOutcome::ClippedAfterAllSteps);
    EXPECT_EQ(controller.status().text(), "preview; still clipped after 4 brackets");
}

TEST(ExposureController, ASourceClippedAtTheShortestExposureEndsTheBracketThere) {
    for (int delay : {0, 3}) {
        SCOPED_TRACE(delay);
        // 20 us shortest: 1/64 of ~10 ms is 156 us (clipped), 1/4096 is 2.4 us, asked at 20 us.
        FakeCamera cam(delay, 1e6, 20e-6);
        ExposureControlSettings settings;
        settings.min_exposure_s = 20e-6;
        ExposureController controller(settings);
        std::vector<Step> s = run(controller, cam, 1 + 2 * (delay + 1));
        ASSERT_TRUE(s[0].request);
        ASSERT_TRUE(s.back().request);
        EXPECT_TRUE(s.back().request->automatic);
        EXPECT_DOUBLE_EQ(s.back().exposure_gain, 20e-6);
        EXPECT_TRUE(s.back().clipped);
        EXPECT_EQ(controller.status().last, BracketOutcome::ClippedAtShortest);
        EXPECT_NE(controller.status().text().find("clipped at the shortest exposure (2e-05 s)"), std::string::npos)
            << controller.status().text();
        EXPECT_EQ(controller.counters().bracket_frames, 2u);
        EXPECT_EQ(controller.counters().clipped_at_shortest, 1u);
        // No request is ever shorter than the shortest exposure.
        for (const Step& x : s) {
            if (x.request && !x.request->automatic) {
                EXPECT_GE(x.request->exposure_s, 20e-6);
            }
        }
    }
}

TEST(ExposureController, ACameraThatIgnoresTheRequestTimesOutSaysSoAndPreviewResumes) {
    FakeCamera cam(0, 1e5);
    cam.ignore_requests = true;
    ExposureController controller;
    std::vector<Step> s = run(controller, cam, 5);
    EXPECT_EQ(controller.status().text().rfind("bracketing 1 of 4 (waiting 4 frames for ", 0), 0u)
        << controller.status().text();
    s = run(controller, cam, 4);
    ASSERT_TRUE(s.back().request);
    EXPECT_TRUE(s.back().request->automatic);
    EXPECT_FALSE(controller.bracketing());
    EXPECT_EQ(controller.status().last, BracketOutcome::TimedOut);
    EXPECT_EQ(controller.counters().timeouts, 1u);
    EXPECT_EQ(controller.counters().bracket_frames, 0u);
    const std::string text = controller.status().text();
    EXPECT_NE(text.find("timed out: the camera did not deliver 0.000156 s at gain 1 within 8 frames"),
              std::string::npos)
        << text;
    // The camera listens again and the source has gone: preview, no requests.
    cam.ignore_requests = false;
    cam.source_in_view = false;
    s = run(controller, cam, 5);
    EXPECT_TRUE(request_frames(s).empty());
    EXPECT_FALSE(controller.bracketing());
}

TEST(ExposureController, ACameraThatStaysOnTheBracketsExposureIsNamedAfterTheWait) {
    FakeCamera cam(0, 1e5);
    cam.ignore_automatic = true;
    ExposureController controller;
    const std::vector<Step> s = run(controller, cam, 12);
    // Brackets after frames 0 and 1; automatic after frame 2 (unclipped), ignored: frames 3-10
    // stay on 1/4096 and are waited through, then the status says so and asks again.
    EXPECT_EQ(request_frames(s), (std::vector<int>{0, 1, 2, 10}));
    EXPECT_TRUE(s[10].request->automatic);
    EXPECT_DOUBLE_EQ(s[10].exposure_gain, s[0].exposure_gain / 4096);
    EXPECT_EQ(controller.status().last, BracketOutcome::NotResumed);
    EXPECT_EQ(controller.counters().not_resumed, 1u);
    EXPECT_EQ(controller.counters().timeouts, 0u);
    EXPECT_NE(controller.status().text().find("automatic exposure not resumed"), std::string::npos)
        << controller.status().text();
    // Still on 1/4096: frame 11 is a view now, and does not clip.
    EXPECT_FALSE(s[11].request);
    EXPECT_FALSE(controller.bracketing());
}

TEST(ExposureController, NothingClippedNoRequests) {
    FakeCamera cam(2, 1e5);
    cam.source_in_view = false;
    ExposureController controller;
    EXPECT_TRUE(request_frames(run(controller, cam, 20)).empty());
    EXPECT_EQ(controller.counters().frames, 20u);
    EXPECT_EQ(controller.counters().clipped_frames, 0u);
    EXPECT_EQ(controller.status().text(), "preview");
}

TEST(ExposureController, BadSettingsAreErrorsNamingTheSetting) {
    const auto message = [](ExposureControlSettings s) {
        try {
            ExposureController c(s);
        } catch (const InputError& e) {
            return std::string(e.what());
        }
        return std::string();
    };
    ExposureControlSettings s;
    s.step_factor = 1;
    EXPECT_NE(message(s).find("step_factor"), std::string::npos);
    s = {};
    s.max_steps = 0;
    EXPECT_NE(message(s).find("max_steps"), std::string::npos);
    s = {};
    s.match_tolerance = 7;  // 8^2 = step_factor: two brackets could match one frame
    EXPECT_NE(message(s).find("match_tolerance"), std::string::npos);
    s = {};
    s.max_wait_frames = 0;
    EXPECT_NE(message(s).find("max_wait_frames"), std::string::npos);
}

// The real simulator as a CameraSource, driven through the controller: a lamp 3e4 times the sky
// in view clips at auto-exposure; the last frame of each bracket has no clipped pixel.
TEST(ExposureController, DrivesTheCameraSimulatorUntilTheBrightViewHasNoClippedPixel) {
    const int w = 256, h = 128;
    HdrImage env(w, h);
    for (int j = 0; j < h; ++j)
        for (int i = 0; i < w; ++i) {
            const glm::dvec3 d = texel_direction(i, j, w, h);
            const float sky = float(0.5 + 0.3 * (d.y + 1));
            const float l = glm::dot(d, glm::dvec3(0, 0, -1)) > std::cos(0.1) ? 3e4f * sky : sky;
            env.set(i, j, {l, 0.8f * l, 0.6f * l});
        }
    CameraCalibration cal;
    cal.intrinsics = Intrinsics::from_fov(96, 54, 70 * kPi / 180);
    cal.vignetting = {-0.2, 0.02, 0};
    sim::CameraRun run;
    run.world_from_camera = [](double) { return sim::camera_look(0, 0); };  // looks along -Z at the lamp
    run.fps = 10;
    run.frames = 40;
    host::VirtualClock clock(1'000'000);
    sim::CameraSimulator simulator(env, cal, run, clock);
    CameraSource& cam = simulator;
    ExposureController controller;
    cam.start();
    int brackets_ended = 0;
    bool was_bracketing = false;
    while (const auto f = cam.next_frame(std::chrono::milliseconds(1000))) {
        const auto r = controller.on_frame(*f);
        if (was_bracketing && !controller.bracketing()) {
            ++brackets_ended;
            EXPECT_EQ(controller.status().last, BracketOutcome::Unclipped) << controller.status().text();
            EXPECT_EQ(ExposureController::clipped_pixels(f->rgb, 255, 1 << 30), 0) << "frame " << f->sequence;
            EXPECT_GT(f->exposure_s, 0);
        }
        was_bracketing = controller.bracketing();
        if (r) cam.set_exposure(*r);
    }
    EXPECT_GE(brackets_ended, 2);
    // 3e4 x the sky needs at least two steps of 64 below an exposure that holds the sky.
    EXPECT_GE(controller.counters().bracket_frames, 2u * std::uint64_t(brackets_ended));
    EXPECT_EQ(controller.counters().timeouts, 0u);
    EXPECT_GT(controller.counters().clipped_frames, 0u);
}

}  // namespace
}  // namespace glint::capture
