#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <regex>
#include <sstream>
#include <unistd.h>

#include "appliance/capture/calibration.hpp"
#include "appliance/capture/calibration_io.hpp"
#include "appliance/capture/calibration_truth.hpp"
#include "appliance/capture/capture_pipeline.hpp"
#include "appliance/capture/charuco.hpp"
#include "appliance/capture/replay_camera.hpp"
#include "appliance/capture/session.hpp"
#include "appliance/core/errors.hpp"
#include "appliance/core/rotation.hpp"
#include "appliance/core/exr_io.hpp"
#include "appliance/sim/session_simulator.hpp"
#include "firmware_bridge/recording/reader.hpp"

namespace glint::capture {
namespace {

using sim::camera_look;
using sim::simulate_charuco_session;
using sim::simulate_session;
using sim::SimulateOptions;
using sim::SimulateSummary;

namespace fs = std::filesystem;

// As `glint capture` does it: the session's frames through a replay camera, as fast as read.
// A capture of the test's session into `out` at width x height, drift correction off unless a
// test turns it on.
CaptureOptions capture_options(const fs::path& session, const fs::path& out, int width, int height,
                               OrientationInput orientations) {
    CaptureOptions c;
    c.session = session;
    c.out = out;
    c.width = width;
    c.height = height;
    c.orientations = orientations;
    c.drift_correction = false;
    return c;
}

CaptureSummary capture_session(const CaptureOptions& c) {
    host::VirtualClock clock;
    ReplayCamera camera(open_session(c.session), clock);
    return run_capture(c, camera);
}

class SessionTest : public ::testing::Test {
protected:
    void SetUp() override {
        dir_ = fs::temp_directory_path() / ("glint-session-test-" + std::to_string(::getpid()));
        fs::remove_all(dir_);
        fs::create_directories(dir_);
        // A small sky: brighter up, a warm band at the horizon, a lamp.
        HdrImage env(128, 64);
        for (int j = 0; j < 64; ++j)
            for (int i = 0; i < 128; ++i) {
                const glm::dvec3 d = texel_direction(i, j, 128, 64);
                double l = 0.3 + 0.4 * (d.y + 1) + 0.2 * std::exp(-20 * d.y * d.y);
                if (glm::dot(d, glm::dvec3(0.6, 0.3, -0.74)) > 0.995) l *= 20;
                env.set(i, j, {float(l), float(0.9 * l), float(0.7 * l)});
            }
        save_exr(dir_ / "env.exr", env);
    }
    void TearDown() override { fs::remove_all(dir_); }

    SimulateOptions small_session() const {
        SimulateOptions o;
        o.env = dir_ / "env.exr";
        o.out = dir_ / "session";
        o.fps = 1.0;
        o.width = 96;
        o.height = 54;
        o.threads = 2;
        return o;
    }
    // A real room (blender-data's studio) scanned with the raw IMU's Mahony fusion plus a heading
    // drift of 1 deg/min (the capture benchmark's condition), 160x90 frames at 3 fps: 15 degrees
    // between frames at the scan's 45 deg/s, so most of a frame overlaps the last.
    SimulateOptions studio_scan() const {
        SimulateOptions o = small_session();
        o.env = std::string(GLINT_BLENDER_WORLDS) + "/studio.exr";
        o.width = 160;
        o.height = 90;
        o.heading_drift_deg_per_min = 1.0;
        o.fps = 3;
        return o;
    }
    // The session captured at 512x256 from its sensors with drift correction, twice: the scan's
    // refinement of calibration.json off (kept.exr), then at its default, stale (refined.exr).
    // `c` is left as the second capture's options, for variants of it.
    std::pair<CaptureSummary, CaptureSummary> capture_kept_and_refined(CaptureOptions& c) const {
        c = capture_options(dir_ / "session", dir_ / "kept.exr", 512, 256, OrientationInput::Sensors);
        c.drift_correction = true;
        c.calibration_refinement = CaptureOptions::CalibrationRefinement::Off;
        CaptureSummary kept = capture_session(c);
        c.out = dir_ / "refined.exr";
        c.calibration_refinement = CaptureOptions::CalibrationRefinement::Stale;
        return {std::move(kept), capture_session(c)};
    }
    fs::path dir_;
};

TEST_F(SessionTest, SimulateThenCaptureWithTrueOrientationsCoversAndMatchesTheSky) {
    const SimulateSummary sim = simulate_session(small_session());
    EXPECT_GT(sim.frames, 40);
    EXPECT_GT(sim.orientation_messages, 1000u);  // ~100 Hz for ~53 s
    const Session s = open_session(dir_ / "session");
    EXPECT_EQ(int(s.frames.size()), sim.frames);
    EXPECT_TRUE(s.has_truth);
    EXPECT_FALSE(s.sensors.empty());
    EXPECT_NO_THROW(recording::RecordingReader(s.sensors.string()));
    EXPECT_FALSE(fs::exists(dir_ / "session.partial"));

    // The accumulation and the sensor path alone (drift correction: its own test).
    CaptureOptions c = capture_options(dir_ / "session", dir_ / "env-captured.exr", 128, 64, OrientationInput::Truth);
    const CaptureSummary r = capture_session(c);
    EXPECT_EQ(r.frames_used, sim.frames);
    // The guided scan sees everything but the floor under the stand (below about -80 degrees).
    EXPECT_GT(r.coverage.covered_fraction, 0.9);
    // The largest unseen cap: the floor, or the lamp (20x the sky), which clips in every frame of
    // a session without brackets, with the texels whose footprint reaches its clipped pixels.
    const glm::dvec3 lamp = glm::normalize(glm::dvec3(0.6, 0.3, -0.74));
    EXPECT_TRUE(r.coverage.largest_gap.y < -0.9 || glm::dot(r.coverage.largest_gap, lamp) > std::cos(0.35))
        << "largest gap at " << r.coverage.largest_gap.x << " " << r.coverage.largest_gap.y << " "
        << r.coverage.largest_gap.z;
    ASSERT_TRUE(r.truth_error);
    EXPECT_LT(r.truth_error->median_relative, 0.05);
    EXPECT_LT(r.truth_error->weighted_relative_rms, 0.15);
    EXPECT_TRUE(fs::exists(c.out));
    EXPECT_TRUE(fs::exists(dir_ / "env-captured.coverage.exr"));
    const HdrImage cov = load_exr(dir_ / "env-captured.coverage.exr").image;
    EXPECT_EQ(cov.width(), 128);

    // The same session through the recorded sensor stream (replayed through the serial driver's
    // decode path and clock mapping, then the mounting): what the appliance itself would do.
    c.orientations = OrientationInput::Sensors;
    c.out = dir_ / "env-from-sensors.exr";
    const CaptureSummary viaSensors = capture_session(c);
    EXPECT_EQ(viaSensors.frames_used, sim.frames);
    ASSERT_TRUE(viaSensors.orientation_error_median_deg);
    EXPECT_LT(*viaSensors.orientation_error_median_deg, 1.0);
    EXPECT_LT(*viaSensors.orientation_error_max_deg, 3.0);
    EXPECT_GT(viaSensors.coverage.covered_fraction, 0.9);
    ASSERT_TRUE(viaSensors.truth_error);
    EXPECT_LT(viaSensors.truth_error->median_relative, 0.08);
    // The guided-capture logic, run over the scan as if live, says "complete" before its end.
    ASSERT_TRUE(viaSensors.guided_complete_after_s);
    EXPECT_LT(*viaSensors.guided_complete_after_s, sim.duration_s);
}

TEST_F(SessionTest, CaptureAppliesTheCalibratedTimeOffset) {
    // Frames stamped 80 ms before the sensor's time of the instant they show, and the offset in
    // the session's calibration: the capture must look the sensor up at frame time + offset. At
    // the scan's 45 deg/s an ignored offset puts the camera about 3.6 degrees off, one applied
    // the wrong way about 7.
    SimulateOptions o = small_session();
    o.time_offset_s = 0.080;
    simulate_session(o);
    // The sensor path alone.
    CaptureOptions c = capture_options(dir_ / "session", dir_ / "env.exr", 128, 64, OrientationInput::Sensors);
    const CaptureSummary with = capture_session(c);
    // The same session with the offset taken out of its calibration.
    CameraCalibration cal = load_calibration(dir_ / "session" / "calibration.json");
    EXPECT_DOUBLE_EQ(cal.time_offset_s, 0.080);
    cal.time_offset_s = 0;
    save_calibration(dir_ / "session" / "calibration.json", cal);
    const CaptureSummary without = capture_session(c);
    ASSERT_TRUE(with.orientation_error_median_deg && without.orientation_error_median_deg);
    std::printf("capture of a session with an 80 ms time offset: camera error median %.3f degrees with the offset "
                "applied, %.3f without\n",
                *with.orientation_error_median_deg, *without.orientation_error_median_deg);
    // Measured 0.229 degrees with the offset (the sensor's own error, as with no offset) and 3.748
    // without it.
    EXPECT_LT(*with.orientation_error_median_deg, 1.0);
    EXPECT_GT(*without.orientation_error_median_deg, 2.0);
}

TEST_F(SessionTest, DriftCorrectionBringsTheCameraCloserToTheTruth) {
    // The heading drift of studio_scan(), which the overlapping frames of the scan can correct.
    simulate_session(studio_scan());
    CaptureOptions c = capture_options(dir_ / "session", dir_ / "plain.exr", 512, 256, OrientationInput::Sensors);
    const CaptureSummary plain = capture_session(c);
    c.out = dir_ / "corrected.exr";
    c.drift_correction = true;
    const CaptureSummary corrected = capture_session(c);
    ASSERT_TRUE(plain.orientation_error_median_deg && corrected.orientation_error_median_deg);
    std::printf("camera orientation error median: %.3f degrees from the sensor alone, %.3f with drift correction "
                "(%d of %d frames corrected)\n",
                *plain.orientation_error_median_deg, *corrected.orientation_error_median_deg, corrected.drift_applied,
                corrected.drift_considered);
    EXPECT_GT(corrected.drift_applied, corrected.drift_considered / 2);
    EXPECT_LT(*corrected.orientation_error_median_deg, *plain.orientation_error_median_deg);
    EXPECT_LT(corrected.drift_residual_after, corrected.drift_residual_before);
    std::printf("global adjustment: %d of %d pairs, pair RMS %.4f degrees, sensor RMS %.4f degrees, drift %.3f "
                "deg/min (injected 1); live error median %.3f max %.3f, final median %.3f max %.3f degrees\n",
                corrected.adjust_pairs, corrected.adjust_pairs_tried, corrected.adjust_pair_rms_deg,
                corrected.adjust_sensor_rms_deg, corrected.adjust_drift_deg_per_min,
                corrected.live_orientation_error_median_deg.value_or(-1),
                corrected.live_orientation_error_max_deg.value_or(-1), *corrected.orientation_error_median_deg,
                corrected.orientation_error_max_deg.value_or(-1));
    // The global adjustment ran on the corrected capture only (it needs the drift correction).
    EXPECT_EQ(plain.adjust_pairs, 0);
    // Most candidate pairs of a scan this dense overlap well enough to be measured (665 of 731).
    EXPECT_GT(corrected.adjust_pairs, corrected.adjust_pairs_tried / 2);
    EXPECT_LE(corrected.adjust_pairs, corrected.adjust_pairs_tried);
    // The drift rate it finds is the injected one. Measured 0.66 deg/min for the injected 1 with
    // the adjustment during the scan (1.33 after it, in 4 rounds; the
    // summary holds its length only, so the sign is the unit test's job:
    // GlobalAdjustment.ThePoseGraphRemovesTheSensorsDriftAndKeepsItsFrame); an adjustment that
    // loses the drift term finds about 0.
    EXPECT_NEAR(corrected.adjust_drift_deg_per_min, 1.0, 0.5);
    // After the solve the pairs agree with the orientations to a fraction of a degree (0.12
    // measured) and the orientations stay near the sensor's (0.37 RMS, its fusion noise).
    EXPECT_LT(corrected.adjust_pair_rms_deg, 0.3);
    EXPECT_LT(corrected.adjust_sensor_rms_deg, 0.8);
    // The adjustment improves on the live pass where it is worst (1.07 -> 0.47 degrees measured)
    // and does not make the typical frame worse (0.471 -> 0.347).
    ASSERT_TRUE(corrected.live_orientation_error_max_deg && corrected.orientation_error_max_deg);
    EXPECT_LT(*corrected.orientation_error_max_deg, *corrected.live_orientation_error_max_deg);
    EXPECT_LE(*corrected.orientation_error_median_deg, *corrected.live_orientation_error_median_deg + 0.02);
    // Its calibration is right: neither the check during the scan nor the one after keeps a
    // refined solution.
    EXPECT_FALSE(corrected.calibration_refined_during_scan_s.has_value());
    EXPECT_FALSE(corrected.calibration_refined);
}

// A calibration.json gone stale: the camera was knocked on its mount (3 degrees) and the sensor's
// latency changed (12 ms) since the calibration. The scan's own refinement finds it, keeps that
// solution and says so; without it the frames stay degrees off.
TEST_F(SessionTest, AStaleCalibrationIsFoundAndTheScanCorrectsIt) {
    simulate_session(studio_scan());
    const fs::path calibration = dir_ / "session" / "calibration.json";
    const CameraCalibration right = load_calibration(calibration);
    CameraCalibration stale = right;
    const glm::dquat knocked = rotation_from_vector(glm::dvec3(1.5, -2.0, 1.2) * (kPi / 180));  // 2.8 degrees
    stale.sensor_from_camera = unit_rotation(stale.sensor_from_camera * knocked);
    stale.time_offset_s -= 0.012;
    save_calibration(calibration, stale);

    CaptureOptions c;
    const auto [kept, refined] = capture_kept_and_refined(c);
    // The same found near the scan's end (it ends at about 53 s): the map begun before is not
    // used, the rebuild begun after the adoption is finished after the last frame, and the pairs
    // aligned from the stale start are aligned again then.
    c.out = dir_ / "refined-late.exr";
    c.scan_check_from_s = 50;
    const CaptureSummary late = capture_session(c);
    // The same with the check after the scan only: every frame accumulated again after the last.
    c.out = dir_ / "refined-after.exr";
    c.scan_check_from_s = 0;
    const CaptureSummary after = capture_session(c);
    ASSERT_TRUE(kept.orientation_error_median_deg && refined.orientation_error_median_deg);
    std::printf("stale calibration: refinement turns the frames %.3f degrees RMS (mounting %.3f degrees, time "
                "offset %+.2f ms); orientation error median %.3f -> %.3f, max %.3f -> %.3f degrees\n",
                refined.calibration_turn_deg, refined.calibration_mounting_deg, refined.calibration_time_offset_ms,
                *kept.orientation_error_median_deg, *refined.orientation_error_median_deg,
                kept.orientation_error_max_deg.value_or(-1), refined.orientation_error_max_deg.value_or(-1));
    // Found either way (Off still measures it); kept only by Stale.
    EXPECT_TRUE(kept.calibration_stale);
    EXPECT_FALSE(kept.calibration_refined);
    EXPECT_TRUE(refined.calibration_stale);
    EXPECT_TRUE(refined.calibration_refined);
    EXPECT_GT(refined.calibration_turn_deg, 1.0);
    EXPECT_GT(*kept.orientation_error_median_deg, 1.0);
    EXPECT_LT(*refined.orientation_error_median_deg, 0.4);
    EXPECT_LT(*refined.orientation_error_median_deg, *kept.orientation_error_median_deg / 3);
    // Found during the scan (from 35 s, 2.8 degrees against the check's 1), so the kept map was
    // rebuilt with the scan's values while it went on: after the last frame only the held-back
    // tail is accumulated, where the check after the scan accumulates every frame again; the
    // frames end as near the truth either way.
    std::printf("found during the scan at %.1f s: %d frames accumulated after the last (after the scan only: %d), "
                "orientation error median %.3f (%.3f) degrees\n",
                refined.calibration_refined_during_scan_s.value_or(-1), refined.map_final_frames, after.map_final_frames,
                *refined.orientation_error_median_deg, after.orientation_error_median_deg.value_or(-1));
    ASSERT_TRUE(refined.calibration_refined_during_scan_s.has_value());
    EXPECT_GE(*refined.calibration_refined_during_scan_s, CaptureOptions{}.scan_check_from_s);
    EXPECT_LT(*refined.calibration_refined_during_scan_s, 45.0);
    EXPECT_LT(refined.map_final_frames, refined.frames_used / 4);
    EXPECT_FALSE(after.calibration_refined_during_scan_s.has_value());
    EXPECT_TRUE(after.calibration_refined);
    EXPECT_EQ(after.map_final_frames, after.frames_used);
    ASSERT_TRUE(after.orientation_error_median_deg);
    EXPECT_LT(*refined.orientation_error_median_deg, *after.orientation_error_median_deg + 0.1);
    std::printf("found late, at %.1f s: %d frames accumulated after the last, orientation error median %.3f, max %.3f "
                "degrees, turn %.2f degrees (%.2f during the scan)\n",
                late.calibration_refined_during_scan_s.value_or(-1), late.map_final_frames,
                late.orientation_error_median_deg.value_or(-1), late.orientation_error_max_deg.value_or(-1),
                late.calibration_turn_deg, late.calibration_turn_during_scan_deg);
    ASSERT_TRUE(late.calibration_refined_during_scan_s.has_value() && late.orientation_error_median_deg);
    EXPECT_GE(*late.calibration_refined_during_scan_s, 50.0);
    EXPECT_GT(late.map_final_frames, late.frames_used / 2);
    EXPECT_LT(*late.orientation_error_median_deg, *after.orientation_error_median_deg + 0.1);
    EXPECT_TRUE(late.calibration_stale);
    EXPECT_GT(late.calibration_turn_during_scan_deg, 1.0);
    // What the kiosk logs and its maintenance menu shows: stale, with what to do, and which
    // calibration the map was made with.
    const std::string kept_text = calibration_check_text(kept), refined_text = calibration_check_text(refined);
    EXPECT_EQ(refined_text.rfind("stale: ", 0), 0u) << refined_text;
    EXPECT_NE(refined_text.find("Run the sensor-camera alignment calibration."), std::string::npos) << refined_text;
    EXPECT_NE(refined_text.find("Its map and AR view used the scan's own values"), std::string::npos) << refined_text;
    // The calibration the map was made with, which the kiosk's AR view takes: near the right one
    // again (the turn the frames make, mounting and time offset at the scan's speed, is what the
    // scan measures; the mounting alone trades its yaw against the time offset).
    const CameraCalibration of_scan = calibration_of_scan(stale, refined);
    const double mounting_error_deg = angle_between(of_scan.sensor_from_camera, right.sensor_from_camera) * 180.0 / kPi;
    const double stale_error_deg = angle_between(stale.sensor_from_camera, right.sensor_from_camera) * 180.0 / kPi;
    std::printf("the scan's calibration: mounting %.3f degrees from the right one (calibration.json %.3f), time offset "
                "%+.1f ms (calibration.json %+.1f)\n",
                mounting_error_deg, stale_error_deg, (of_scan.time_offset_s - right.time_offset_s) * 1e3,
                (stale.time_offset_s - right.time_offset_s) * 1e3);
    // Measured 0.18 degrees (2.77 in the file) and +3.5 ms (-12; the fusion's own lag reads as
    // 3-8 ms of offset, docs/capture.md).
    EXPECT_LT(mounting_error_deg, 0.6);
    EXPECT_LT(std::abs(of_scan.time_offset_s - right.time_offset_s), 0.008);
    // Without a kept refinement it is calibration.json's.
    const CameraCalibration of_kept = calibration_of_scan(stale, kept);
    EXPECT_EQ(of_kept.sensor_from_camera, stale.sensor_from_camera);
    EXPECT_EQ(of_kept.time_offset_s, stale.time_offset_s);
    EXPECT_NE(kept_text.find("Its map was made with the calibration as it is."), std::string::npos) << kept_text;
}

// A calibration less stale (the mounting 0.6 degrees off): a partial scan's turn is not past the
// first limit at 35 s, but past the later, lower one (CaptureOptions::scan_check_late_*), so it is
// still found during the scan and the visitor does not wait for every frame again.
TEST_F(SessionTest, AModeratelyStaleCalibrationIsFoundLaterInTheScan) {
    simulate_session(studio_scan());
    const fs::path calibration = dir_ / "session" / "calibration.json";
    CameraCalibration stale = load_calibration(calibration);
    const glm::dvec3 axis = glm::normalize(glm::dvec3(1.5, -2.0, 1.2));
    stale.sensor_from_camera = unit_rotation(stale.sensor_from_camera * rotation_from_vector(axis * (0.6 * kPi / 180)));
    save_calibration(calibration, stale);
    CaptureOptions c = capture_options(dir_ / "session", dir_ / "refined.exr", 512, 256, OrientationInput::Sensors);
    c.drift_correction = true;
    const CaptureSummary refined = capture_session(c);
    std::string checks;
    for (const CaptureSummary::CalibrationCheck& check : refined.calibration_checks_during_scan)
        checks += std::to_string(check.t_s) + " s: " + std::to_string(check.turn_deg) + " deg; ";
    std::printf("0.6 degrees stale: checks during the scan %s found at %.1f s, %d of %d frames accumulated after the "
                "last, whole scan's turn %.3f degrees, orientation error median %.3f degrees\n",
                checks.c_str(), refined.calibration_refined_during_scan_s.value_or(-1), refined.map_final_frames,
                refined.frames_used, refined.calibration_turn_deg, refined.orientation_error_median_deg.value_or(-1));
    const CaptureOptions defaults;
    ASSERT_FALSE(refined.calibration_checks_during_scan.empty());
    // The first check is under the first limit: this is the later limit's case.
    EXPECT_LT(refined.calibration_checks_during_scan.front().turn_deg, defaults.scan_check_stale_deg);
    ASSERT_TRUE(refined.calibration_refined_during_scan_s.has_value()) << checks;
    EXPECT_GE(*refined.calibration_refined_during_scan_s, defaults.scan_check_late_from_s);
    // Kept by the lower limit: the turn that kept it was under the first one.
    EXPECT_LT(refined.calibration_turn_during_scan_deg, defaults.scan_check_stale_deg);
    EXPECT_TRUE(refined.calibration_stale);
    EXPECT_LT(refined.map_final_frames, refined.frames_used / 2);
    ASSERT_TRUE(refined.orientation_error_median_deg.has_value());
    EXPECT_LT(*refined.orientation_error_median_deg, 0.4);
}

// A time offset off alone turns the fast frames most, the scan's RMS turn little: the shipped kiosk
// session with its time offset 15 ms off turned 0.398 degrees, under both turn limits, and its map
// was 0.137 off the truth against 0.074 with the scan's values. The limit on the time offset's
// change (kStaleTimeOffsetMs, and from scan_check_late_from_s during the scan) finds it. Here
// (studio, 160x90 frames, 13 ms) the partial scans' turns stay under the later turn limit, so
// without it the calibration would be found after the scan only, by the whole scan's turn
// (measured 2026-12-07: 0.46 degrees and -8.8 ms at 40.7 s, the whole scan 0.50 degrees; the map
// 0.0354 against 0.0442 with calibration.json).
TEST_F(SessionTest, ATimeOffsetOffIsFoundByItselfDuringTheScan) {
    simulate_session(studio_scan());
    const fs::path calibration = dir_ / "session" / "calibration.json";
    const CameraCalibration right = load_calibration(calibration);
    CameraCalibration stale = right;
    stale.time_offset_s += 0.013;
    save_calibration(calibration, stale);
    CaptureOptions c;
    const auto [kept, refined] = capture_kept_and_refined(c);
    std::string checks;
    for (const CaptureSummary::CalibrationCheck& check : refined.calibration_checks_during_scan)
        checks += std::to_string(check.t_s) + " s: " + std::to_string(check.turn_deg) + " deg " +
                  std::to_string(check.time_offset_ms) + " ms; ";
    ASSERT_TRUE(kept.truth_error && refined.truth_error);
    std::printf("time offset 13 ms off: checks during the scan %s found at %.1f s; whole scan: turn %.3f degrees, time "
                "offset %+.2f ms; map against the truth %.4f (calibration.json kept: %.4f)\n",
                checks.c_str(), refined.calibration_refined_during_scan_s.value_or(-1), refined.calibration_turn_deg,
                refined.calibration_time_offset_ms, refined.truth_error->weighted_relative_rms,
                kept.truth_error->weighted_relative_rms);
    const CaptureOptions defaults;
    // Measured and reported with the refinement off too; not kept then.
    EXPECT_TRUE(kept.calibration_stale);
    EXPECT_FALSE(kept.calibration_refined);
    ASSERT_TRUE(refined.calibration_refined_during_scan_s.has_value()) << checks;
    EXPECT_GE(*refined.calibration_refined_during_scan_s, defaults.scan_check_late_from_s);
    // Found by the time offset: the turn that kept it was under the later turn limit, and the
    // first check, before the time offset's limit applies, read it over that limit already.
    EXPECT_LT(refined.calibration_turn_during_scan_deg, defaults.scan_check_late_stale_deg);
    EXPECT_LT(refined.calibration_checks_during_scan.front().t_s, defaults.scan_check_late_from_s);
    EXPECT_GT(std::abs(refined.calibration_checks_during_scan.front().time_offset_ms),
              defaults.scan_check_late_stale_offset_ms);
    EXPECT_GT(std::abs(refined.calibration_checks_during_scan.back().time_offset_ms),
              defaults.scan_check_late_stale_offset_ms);
    EXPECT_TRUE(refined.calibration_stale);
    EXPECT_LT(refined.map_final_frames, refined.frames_used / 2);
    // The map made with the scan's values is nearer the truth, and its time offset nearer the
    // right one (which the board's fusion lag, a few ms, keeps it from reaching).
    EXPECT_LT(refined.truth_error->weighted_relative_rms, kept.truth_error->weighted_relative_rms);
    const double scan_offset_ms = (calibration_of_scan(stale, refined).time_offset_s - right.time_offset_s) * 1e3;
    EXPECT_LT(std::abs(scan_offset_ms), 7.0) << scan_offset_ms;
}

// The check's line when it was within the limit, and when no refined solve ran (no drift
// correction, or the rounds mode): nothing is claimed.
TEST(CalibrationCheck, TextSaysOkWithinTheLimitAndNothingWhenNotChecked) {
    CaptureSummary s;
    EXPECT_EQ(calibration_check_text(s), "n/a");
    s.calibration_turn_deg = 3.0;  // figures without a check are not shown
    EXPECT_EQ(calibration_check_text(s), "n/a");
    s.calibration_checked = true;
    s.calibration_turn_deg = 0.18;
    s.calibration_time_offset_ms = 3.5;
    const std::string ok = calibration_check_text(s);
    EXPECT_EQ(ok.rfind("ok: ", 0), 0u) << ok;
    EXPECT_NE(ok.find("0.18"), std::string::npos) << ok;
    EXPECT_NE(ok.find("+3.5 ms"), std::string::npos) << ok;  // the figure the second limit reads
    EXPECT_EQ(ok.find("Run the"), std::string::npos) << ok;
}

// Stale is either limit passed: the turn of the frames, or the time offset's change either way
// (a time offset off turns the fast frames most, and an RMS over every frame hides it).
TEST(CalibrationCheck, EitherTheTurnOrTheTimeOffsetMakesItStale) {
    EXPECT_FALSE(calibration_turn_or_offset_stale(0.39, 6.9, 0.4, 7.0));
    EXPECT_FALSE(calibration_turn_or_offset_stale(0.39, -6.9, 0.4, 7.0));
    EXPECT_FALSE(calibration_turn_or_offset_stale(0.4, 7.0, 0.4, 7.0));  // at a limit is within it
    EXPECT_TRUE(calibration_turn_or_offset_stale(0.41, 0.0, 0.4, 7.0));
    EXPECT_TRUE(calibration_turn_or_offset_stale(0.1, 7.1, 0.4, 7.0));
    EXPECT_TRUE(calibration_turn_or_offset_stale(0.1, -11.4, 0.4, 7.0));
    // No time offset limit: the turn alone.
    EXPECT_FALSE(calibration_turn_or_offset_stale(0.3, 50.0, 0.4, std::numeric_limits<double>::infinity()));
    // A refinement that failed to a NaN is not a finding, even where the other figure passes.
    EXPECT_FALSE(calibration_turn_or_offset_stale(std::nan(""), std::nan(""), 0.4, 7.0));
    EXPECT_FALSE(calibration_turn_or_offset_stale(std::nan(""), 10.0, 0.4, 7.0));
    EXPECT_FALSE(calibration_turn_or_offset_stale(2.0, std::nan(""), 0.4, 7.0));
    EXPECT_FALSE(calibration_turn_or_offset_stale(std::numeric_limits<double>::infinity(), 0.0, 0.4, 7.0));
}

// The scan's refinement is a turn in the camera frame, after the mounting: world_from_camera =
// world_from_sensor x sensor_from_camera x exp(delta) (AdjustmentResult::mounting_rad).
TEST(CalibrationCheck, TheScansCalibrationTurnsTheMountingInTheCameraFrame) {
    CameraCalibration file;
    file.sensor_from_camera = rotation_from_vector(glm::dvec3(kPi / 2, 0, 0));
    file.time_offset_s = 0.010;
    CaptureSummary s;
    s.calibration_checked = true;
    s.calibration_mounting_axis = glm::dvec3(0, 0, 1);
    s.calibration_mounting_deg = 90;
    s.calibration_time_offset_ms = 4.5;
    // Not kept: the file's.
    EXPECT_EQ(calibration_of_scan(file, s).sensor_from_camera, file.sensor_from_camera);
    EXPECT_EQ(calibration_of_scan(file, s).time_offset_s, file.time_offset_s);
    s.calibration_refined = true;
    const CameraCalibration c = calibration_of_scan(file, s);
    const glm::dquat expected = file.sensor_from_camera * rotation_from_vector(glm::dvec3(0, 0, kPi / 2));
    EXPECT_LT(angle_between(c.sensor_from_camera, expected), 1e-12);
    // The other order is a different rotation (the test would see a swapped product).
    EXPECT_GT(angle_between(c.sensor_from_camera,
                            rotation_from_vector(glm::dvec3(0, 0, kPi / 2)) * file.sensor_from_camera), 0.5);
    EXPECT_NEAR(c.time_offset_s, 0.0145, 1e-15);
    // The camera's z axis (its view) in the sensor frame: the turn about the camera's own z
    // leaves it where the file's mounting put it.
    const glm::dvec3 view_file = file.sensor_from_camera * glm::dvec3(0, 0, 1), view = c.sensor_from_camera * glm::dvec3(0, 0, 1);
    EXPECT_LT(glm::length(view - view_file), 1e-12);
}

TEST_F(SessionTest, RefusesToReplaceASessionWithoutForce) {
    SimulateOptions o = small_session();
    o.trajectory = (dir_ / "short.csv").string();
    std::ofstream(dir_ / "short.csv") << "0,1,0,0,0\n2,0.9238795,0,0.3826834,0\n";
    ASSERT_NO_THROW(simulate_session(o));
    EXPECT_THROW(simulate_session(o), InputError);
    o.overwrite = true;
    EXPECT_NO_THROW(simulate_session(o));
}

TEST_F(SessionTest, MalformedFilesNameTheFileAndTheLine) {
    SimulateOptions o = small_session();
    o.trajectory = (dir_ / "short.csv").string();
    std::ofstream(dir_ / "short.csv") << "0,1,0,0,0\n1,1,0,0,0\n";
    simulate_session(o);
    const fs::path frames = dir_ / "session" / "frames.csv";
    {
        std::ofstream f(frames, std::ios::app);
        f << "9,notanumber,0.01,1,1,frames/000000.png\n";
    }
    try {
        open_session(dir_ / "session");
        FAIL() << "no error";
    } catch (const InputError& e) {
        EXPECT_NE(std::string(e.what()).find("frames.csv:"), std::string::npos) << e.what();
        EXPECT_NE(std::string(e.what()).find("notanumber"), std::string::npos) << e.what();
    }
    std::ofstream(dir_ / "session" / "calibration.json") << "{\"format\": \"glint-camera-calibration\"}";
    try {
        open_session(dir_ / "session");
        FAIL() << "no error";
    } catch (const InputError& e) {
        EXPECT_NE(std::string(e.what()).find("calibration.json: key 'version'"), std::string::npos) << e.what();
    }
    EXPECT_THROW(open_session(dir_ / "nothing-here"), InputError);
    // nlohmann's other exceptions are InputErrors naming session.json too: a number beyond
    // double's range (out_of_range; tests/fuzz's calibration target found it in that reader), a
    // format that is not a string (type_error from j.value()).
    for (const char* text : {R"({"format": "glint-session", "version": 1e999})", R"({"format": 7, "version": 1})"}) {
        std::ofstream(dir_ / "session" / "session.json") << text;
        try {
            open_session(dir_ / "session");
            ADD_FAILURE() << "no error for " << text;
        } catch (const InputError& e) {
            EXPECT_NE(std::string(e.what()).find("session.json"), std::string::npos) << e.what();
        } catch (const std::exception& e) {
            ADD_FAILURE() << "not an InputError for " << text << ": " << e.what();
        }
    }
    // A session's own file names stay inside it (an absolute path or .. could read any file).
    for (const char* text : {R"({"format": "glint-session", "version": 1, "calibration": "/etc/passwd", "frames": "frames.csv"})",
                             R"({"format": "glint-session", "version": 1, "calibration": "calibration.json", "frames": "../x.csv"})",
                             R"({"format": "glint-session", "version": 1, "calibration": "calibration.json", "frames": "frames.csv", "sensors": "/dev/zero"})"}) {
        std::ofstream(dir_ / "session" / "session.json") << text;
        try {
            open_session(dir_ / "session");
            ADD_FAILURE() << "no error for " << text;
        } catch (const InputError& e) {
            EXPECT_NE(std::string(e.what()).find("not a relative path inside the session"), std::string::npos) << e.what();
        }
    }
}

// Damage found by a sweep of bad inputs (2026-12-06): each refused before the work, naming the
// file at fault, instead of a crash, gigabytes of memory or minutes of waiting.
// `o` is refused with an InputError saying `reason`, before anything is written to o.out.
void expect_simulation_refused(const SimulateOptions& o, const std::string& reason) {
    try {
        simulate_session(o);
        ADD_FAILURE() << "no error: expected '" << reason << "'";
    } catch (const InputError& e) {
        EXPECT_NE(std::string(e.what()).find(reason), std::string::npos) << e.what();
    }
    EXPECT_FALSE(fs::exists(o.out)) << o.out;
}

TEST_F(SessionTest, DamagedSessionsAreRefusedBeforeTheWorkNamingTheFile) {
    SimulateOptions o = small_session();
    o.trajectory = (dir_ / "short.csv").string();
    std::ofstream(dir_ / "short.csv") << "0,1,0,0,0\n2,0.9239,0,0.3827,0\n";  // seconds
    simulate_session(o);
    const fs::path session = dir_ / "session";
    Session s = open_session(session);
    ASSERT_GE(s.frames.size(), 2u);
    {  // A frame list saved with CRLF line ends reads as it is.
        std::ifstream in(session / "frames.csv");
        std::stringstream crlf;
        for (std::string line; std::getline(in, line);) crlf << line << "\r\n";
        in.close();
        std::ofstream(session / "frames.csv", std::ios::trunc) << crlf.str();
        EXPECT_EQ(open_session(session).frames.size(), s.frames.size());
    }
    // A frame smaller than the calibration (the rolling-shutter deskew read past its end: a
    // heap corruption) or a calibration larger than the frames (rays for every pixel of it).
    const fs::path frame = session / s.frames[1].file;
    cv::imwrite(frame.string(), cv::Mat(27, 48, CV_8UC3, cv::Scalar(40, 40, 40)));
    for (const CaptureOptions& c : {capture_options(session, dir_ / "captured.exr", 64, 32, OrientationInput::Sensors),
                                    capture_options(session, dir_ / "captured.exr", 64, 32, OrientationInput::Truth)}) {
        try {
            capture_session(c);
            ADD_FAILURE() << "no error for a 48x27 frame";
        } catch (const InputError& e) {
            EXPECT_NE(std::string(e.what()).find(frame.string() + ": the image is 48x27"), std::string::npos) << e.what();
            EXPECT_NE(std::string(e.what()).find("is for 96x54"), std::string::npos) << e.what();
        }
        EXPECT_FALSE(fs::exists(dir_ / "captured.exr"));
    }
    // load_frame reads it (an intrinsics calibration of a new camera mode reads such frames);
    // readers that index frames by the calibration check its size.
    EXPECT_NO_THROW(load_frame(s, s.frames[1]));
    EXPECT_THROW(check_frame_size(s, s.frames[1], load_frame(s, s.frames[1])), InputError);
    // A frame time years after the one before it (a replay waited out the gap in 1 s steps).
    {
        std::ofstream f(session / "frames.csv", std::ios::app);
        f << "999,9223372036854775807,0.01,1,1," << s.frames[0].file << "\n";
    }
    try {
        open_session(session);
        FAIL() << "no error for a gap of centuries";
    } catch (const InputError& e) {
        EXPECT_NE(std::string(e.what()).find("frames.csv:"), std::string::npos) << e.what();
        EXPECT_NE(std::string(e.what()).find("no gap over an hour"), std::string::npos) << e.what();
    }
    // A frame index repeated (compared with its neighbour's true pose) and exposures and gains no
    // camera has (1e300 s made a map of zeros and a motion blur of 1e300 pixels).
    const auto with_second_line = [&](const std::string& fields, const std::string& expected) {
        std::ofstream f(session / "frames.csv", std::ios::trunc);
        f << frames_csv_header() << "\n" << frames_csv_line(s.frames[0]) << "\n" << fields << "," << s.frames[1].file << "\n";
        f.close();
        try {
            open_session(session);
            ADD_FAILURE() << "no error for " << fields;
        } catch (const InputError& e) {
            EXPECT_NE(std::string(e.what()).find("frames.csv:3: " + expected), std::string::npos) << e.what();
        }
    };
    const std::string t1 = std::to_string(s.frames[1].t_ns), i1 = std::to_string(s.frames[1].index);
    with_second_line(std::to_string(s.frames[0].index) + "," + t1 + ",0.01,1,1", "frame indices must increase");
    with_second_line(i1 + "," + t1 + ",1e300,1,1", "exposure 1e+300 s is outside");
    with_second_line(i1 + "," + t1 + ",1e-300,1,1", "exposure 1e-300 s is outside");
    with_second_line(i1 + "," + t1 + ",0.01,1e9,1", "gain 1e+09 is outside");
    with_second_line(i1 + "," + t1 + ",0.01,1,0.001", "gain 0.001 is outside");
    // A trajectory of 1e9 s (its sensor path at 200 Hz asked for 10 GB).
    std::ofstream(dir_ / "long.csv") << "0,1,0,0,0\n1000000000,1,0,0,0\n";
    o.trajectory = (dir_ / "long.csv").string();
    o.out = dir_ / "long";
    expect_simulation_refused(o, "long.csv: the trajectory lasts 1000000000 s");
}

// A sensor recording cut short (a power loss while recording): the capture still uses the frames
// it can place, and says how many come after the recording's end and by how long.
TEST_F(SessionTest, ARecordingCutShortIsReported) {
    SimulateOptions o = small_session();
    o.fps = 2;
    o.trajectory = (dir_ / "turn.csv").string();
    std::ofstream(dir_ / "turn.csv") << "0,1,0,0,0\n6,0.7071,0,0.7071,0\n";  // seconds
    simulate_session(o);
    const fs::path session = dir_ / "session";
    CaptureOptions c = capture_options(session, dir_ / "captured.exr", 64, 32, OrientationInput::Sensors);
    c.global_adjustment = false;
    const CaptureSummary whole = capture_session(c);
    EXPECT_EQ(whole.frames_after_sensor_end, 0);
    const fs::path recording = open_session(session).sensors;
    fs::resize_file(recording, fs::file_size(recording) / 2);
    const CaptureSummary cut = capture_session(c);
    std::printf("[  report  ] cut recording: %d frames after its end, %.2f s before the last frame, %d without an "
                "orientation\n", cut.frames_after_sensor_end, cut.sensor_end_before_last_frame_s,
                cut.frames_without_orientation);
    EXPECT_GE(cut.frames_after_sensor_end, 3);
    EXPECT_LE(cut.frames_after_sensor_end, cut.frames_without_orientation);
    EXPECT_GT(cut.sensor_end_before_last_frame_s, 1.0);
    EXPECT_GT(cut.frames_used, 0);
}

TEST_F(SessionTest, ResponseCalibrationFromABracketFindsTheTrueCurve) {
    SimulateOptions o = small_session();
    o.env = std::string(GLINT_BLENDER_WORLDS) + "/courtyard.exr";
    o.bracket = 16;
    o.bracket_first_exposure_s = 2e-5;  // the sensor's shortest exposure (camera_model.hpp)
    o.camera_noise = false;
    simulate_session(o);
    const Session s = open_session(dir_ / "session");
    const ResponseResult r = calibrate_response(s);
    EXPECT_EQ(r.frames, 16);
    EXPECT_NEAR(r.exposure_span, 32768.0, 1.0);
    const CameraCalibration truth = load_calibration(dir_ / "session" / "truth" / "calibration.json");
    double worst = 0;
    for (int z = 64; z <= 250; ++z) {
        const double est = r.response.inverse[std::size_t(z)] / r.response.inverse[128];
        const double tru = truth.response.inverse[std::size_t(z)] / truth.response.inverse[128];
        worst = std::max(worst, std::abs(est / tru - 1));
    }
    std::printf("response calibration, noiseless bracket: worst relative error %.2f %% over codes 64..250\n", 100 * worst);
    EXPECT_LT(worst, 0.05);
    for (int z = 1; z < 256; ++z) EXPECT_GT(r.response.inverse[std::size_t(z)], r.response.inverse[std::size_t(z - 1)]);
    // The table survives the calibration file.
    CameraCalibration c = s.calibration;
    c.response = r.response;
    save_calibration(dir_ / "cal.json", c);
    EXPECT_DOUBLE_EQ(load_calibration(dir_ / "cal.json").response.inverse[200], r.response.inverse[200]);
}

// With the sensor's noise, Robertson's estimate of a code's exposure (the mean over the reads of
// that code) is pulled up at the low codes by darker pixels that noise lifted: 28-59 % off over
// codes 64..250 on these brackets before the refinement (docs/capture.md, "Calibration").
TEST_F(SessionTest, ResponseCalibrationIsNotBiasedBySensorNoise) {
    struct Case {
        const char* env;
        int frames;
        double first_s, full_well, read;
    };
    for (const Case& c : {Case{"courtyard.exr", 12, 1e-4, 6000, 0.002}, Case{"studio.exr", 16, 2e-5, 1500, 0.006}}) {
        SimulateOptions o = small_session();
        o.env = std::string(GLINT_BLENDER_WORLDS) + "/" + c.env;
        o.width = 240;
        o.height = 135;
        o.bracket = c.frames;
        o.bracket_first_exposure_s = c.first_s;
        o.camera_full_well_electrons = c.full_well;
        o.camera_read_noise = c.read;
        o.out = dir_ / (std::string("noisy-") + c.env);
        simulate_session(o);
        const Session s = open_session(o.out);
        const ResponseResult r = calibrate_response(s);
        const double error = response_error_against_truth(r.response, truth_calibration(s).response);
        std::printf("response calibration, noisy bracket of %s (%d frames from %g s, %g e-, read %g): worst %.2f %% "
                    "over codes 64..250; %s\n",
                    c.env, c.frames, c.first_s, c.full_well, c.read, 100 * error, response_coverage(r).c_str());
        EXPECT_LT(error, 0.05) << c.env;
        EXPECT_LE(r.measured_low, 32) << c.env;
        EXPECT_GE(r.measured_high, 250) << c.env;
        for (int z = 1; z < 256; ++z) EXPECT_GT(r.response.inverse[std::size_t(z)], r.response.inverse[std::size_t(z - 1)]);
        // Through this curve the noise model comes out as through the true one.
        CameraCalibration calibrated = s.calibration;
        calibrated.response = r.response;
        const NoiseResult n = calibrate_noise(s, calibrated);
        const NoiseError e = noise_error_against_truth(n.full_well_electrons, n.read_noise, r.response, truth_calibration(s));
        std::printf("  noise through it: full well %+.1f %%, read noise %+.1f %%\n", 100 * e.full_well, 100 * e.read_noise);
        EXPECT_LT(std::abs(e.full_well), 0.1) << c.env;
        EXPECT_LT(std::abs(e.read_noise), 0.1) << c.env;
    }
    // A bracket that never exposes a pixel into the shoulder measures no code there, and says so.
    SimulateOptions o = small_session();
    o.env = std::string(GLINT_BLENDER_WORLDS) + "/studio.exr";
    o.width = 240;
    o.height = 135;
    o.bracket = 12;
    o.out = dir_ / "short-bracket";
    simulate_session(o);
    const ResponseResult r = calibrate_response(open_session(o.out));
    EXPECT_LT(r.measured_high, 250);
    EXPECT_NE(response_coverage(r).find("end the bracket longer"), std::string::npos) << response_coverage(r);
}

// A code that never occurs in a channel (a camera's tone curve or digital gain can skip codes)
// is NaN in Robertson's curve; the table must stay finite and scaled (a NaN above the measured
// codes once left code 254 at 45.7 instead of 1, and the noise fit through it 98 % off).
TEST_F(SessionTest, ACodeTheCameraNeverWritesLeavesTheResponseFiniteAndScaled) {
    SimulateOptions o = small_session();
    o.env = std::string(GLINT_BLENDER_WORLDS) + "/courtyard.exr";
    o.width = 160;
    o.height = 90;
    o.bracket = 5;  // codes 34..252 measured: the codes above come from Robertson's curve
    o.out = dir_ / "gap";
    simulate_session(o);
    Session s = open_session(o.out);
    int changed = 0;
    for (const FrameRecord& r : s.frames) {
        cv::Mat bgr = cv::imread((s.dir / r.file).string(), cv::IMREAD_COLOR);
        ASSERT_FALSE(bgr.empty());
        for (int v = 0; v < bgr.rows; ++v)
            for (cv::Vec3b& p : cv::Mat_<cv::Vec3b>(bgr.row(v)))
                if (p[2] == 253) {  // red: code 253 never written
                    p[2] = 252;
                    ++changed;
                }
        ASSERT_TRUE(cv::imwrite((s.dir / r.file).string(), bgr));
    }
    ASSERT_GT(changed, 0);
    s = open_session(o.out);
    const ResponseResult r = calibrate_response(s);
    for (int z = 0; z < 256; ++z) ASSERT_TRUE(std::isfinite(r.response.inverse[std::size_t(z)])) << z;
    EXPECT_NEAR(r.response.inverse[254], 1.0, 1e-12);
    for (int z = 1; z < 256; ++z) EXPECT_GT(r.response.inverse[std::size_t(z)], r.response.inverse[std::size_t(z - 1)]);
    const double error = response_error_against_truth(r.response, truth_calibration(s).response);
    std::printf("response with code 253 never written in red: worst %.2f %% over codes 64..250; %s\n", 100 * error,
                response_coverage(r).c_str());
    EXPECT_LT(error, 0.05);
}

TEST_F(SessionTest, AResponseNeedsARealBracket) {
    SimulateOptions o = small_session();
    o.bracket = 3;  // 4x: too narrow
    simulate_session(o);
    EXPECT_THROW(calibrate_response(open_session(dir_ / "session")), InputError);
    // A bracket whose longest frame frames.csv may not hold (over 100 s) is refused before any
    // file is written: the session would not have opened.
    o.bracket = 25;
    o.out = dir_ / "too-long";
    expect_simulation_refused(o, "--bracket 25 from --bracket-first");
}

// The noise model from a bracket, on two sensors (the simulator's default and a small, noisy
// one), read through the session's (true) response: within 10 % of the truth, which a fit that
// ignored the quantisation or the reads lost below the noise (measured: 27 % and 80 % low) misses.
TEST_F(SessionTest, NoiseCalibrationFromABracketFindsTheSensorsModel) {
    for (const auto& [full_well, read] : {std::pair{6000.0, 0.002}, std::pair{1500.0, 0.006}}) {
        SimulateOptions o = small_session();
        o.env = std::string(GLINT_BLENDER_WORLDS) + "/courtyard.exr";
        o.width = 240;
        o.height = 135;
        o.bracket = 12;
        o.camera_full_well_electrons = full_well;
        o.camera_read_noise = read;
        o.out = dir_ / ("bracket-" + std::to_string(int(full_well)));
        simulate_session(o);
        const Session s = open_session(o.out);
        const NoiseResult r = calibrate_noise(s, s.calibration);
        std::printf("noise calibration, full well %.0f read %.4f: %.0f electrons, read %.5f from %d pairs, %d bins, "
                    "fit RMS %.1f %%\n",
                    full_well, read, r.full_well_electrons, r.read_noise, r.pairs, r.bins, 100 * r.fit_rms);
        EXPECT_EQ(r.pairs, 11);
        EXPECT_NEAR(r.full_well_electrons / full_well, 1.0, 0.1);
        EXPECT_NEAR(r.read_noise / read, 1.0, 0.1);
    }
    // A noiseless bracket shows no shot noise: refused, nothing fitted.
    SimulateOptions o = small_session();
    o.env = std::string(GLINT_BLENDER_WORLDS) + "/courtyard.exr";
    o.bracket = 8;
    o.camera_noise = false;
    o.out = dir_ / "noiseless";
    simulate_session(o);
    const Session quiet = open_session(o.out);
    EXPECT_THROW(calibrate_noise(quiet, quiet.calibration), InputError);
    // Nor is a scan a bracket: its view moves, and its exposures follow the scene.
    SimulateOptions scan = small_session();
    scan.out = dir_ / "scan";
    simulate_session(scan);
    const Session moving = open_session(scan.out);
    EXPECT_THROW(calibrate_noise(moving, moving.calibration), InputError);
}

TEST_F(SessionTest, VignettingFromAFlatFieldFindsTheTrueFalloff) {
    HdrImage flat(64, 32);
    for (int j = 0; j < 32; ++j)
        for (int i = 0; i < 64; ++i) flat.set(i, j, {0.5f, 0.5f, 0.5f});
    save_exr(dir_ / "flat.exr", flat);
    SimulateOptions o = small_session();
    o.env = dir_ / "flat.exr";
    o.trajectory = (dir_ / "still.csv").string();
    std::ofstream(dir_ / "still.csv") << "0,1,0,0,0\n4,1,0,0,0\n";
    o.fps = 2;
    simulate_session(o);
    const Session s = open_session(dir_ / "session");
    const CameraCalibration truth = load_calibration(dir_ / "session" / "truth" / "calibration.json");
    const VignettingResult r = calibrate_vignetting(s, truth);
    EXPECT_EQ(r.frames, 9);
    double worst = 0;
    for (double rr = 0; rr <= 1.0; rr += 0.05) {
        const double r2 = rr * rr;
        const auto v = [&](const Vignetting& g) { return 1 + r2 * (g.a1 + r2 * (g.a2 + r2 * g.a3)); };
        worst = std::max(worst, std::abs(v(r.vignetting) - v(truth.vignetting)));
    }
    std::printf("vignetting from a flat field: a1 %.4f a2 %.4f a3 %.4f (true %.4f %.4f %.4f), worst |dV| %.4f\n",
                r.vignetting.a1, r.vignetting.a2, r.vignetting.a3, truth.vignetting.a1, truth.vignetting.a2,
                truth.vignetting.a3, worst);
    EXPECT_LT(worst, 0.01);
}

// A rotation-only scan of courtyard for the camera-sensor alignment, its frames stamped
// `time_offset_ms` off the sensor's clock (camera time + offset = sensor time).
SimulateOptions alignment_scan(SimulateOptions o, double time_offset_ms) {
    o.env = std::string(GLINT_BLENDER_WORLDS) + "/courtyard.exr";
    o.width = 320;
    o.height = 180;
    o.fps = 3;
    o.time_offset_s = time_offset_ms * 1e-3;
    return o;
}

// The time offset's tolerance. Measured until 2026-12-02: the estimate 2.0 ms below the truth at
// -20, 0 and +35 ms alike (on its 1 ms grid); since the sub-pixel image rotations and the joint
// refinement, -19.4 and +35.6 ms (mounting 0.125 degrees off). 5 ms is still far below the 20
// and 35 ms an estimator that ignores the offset would be off by.
constexpr double kTimeOffsetToleranceMs = 5.0;
// The three-axis motion's tolerances at 160x90. Measured on six seeds (glint simulate): the
// mounting 0.02-0.15 degrees off, the offset within 0.7 ms; this test's seed 0.05 and +0.67 ms.
constexpr double kThreeAxisMountingToleranceDeg = 0.5;
constexpr double kThreeAxisTimeOffsetToleranceMs = 3.0;

TEST_F(SessionTest, AlignmentFromAScanComesCloserThanNoCalibration) {
    // The simulator mounts the sensor 2 / -1.5 / 0.5 degrees (yaw / pitch / roll) off the camera:
    // 2.55 degrees in all. Image rotations between frames of courtyard against the sensor's.
    // The frames run 20 ms behind the sensor: a true offset of 0 would not catch an estimator
    // that always answers 0.
    simulate_session(alignment_scan(small_session(), -20));
    const Session s = open_session(dir_ / "session");
    const CameraCalibration truth = load_calibration(dir_ / "session" / "truth" / "calibration.json");
    EXPECT_DOUBLE_EQ(truth.time_offset_s, -0.020);  // the truth the simulator wrote
    const AlignmentResult r = calibrate_alignment(s);
    const double off = angle_between(r.sensor_from_camera, truth.sensor_from_camera) * 180 / kPi;
    const double uncalibrated = angle_between(glm::dquat(1, 0, 0, 0), truth.sensor_from_camera) * 180 / kPi;
    std::printf("alignment: %d pairs, mounting off by %.3f degrees (%.3f uncalibrated), time offset %.1f ms "
                "(true %.1f), median residual %.3f degrees\n",
                r.pairs, off, uncalibrated, r.time_offset_s * 1e3, truth.time_offset_s * 1e3, r.residual_deg);
    EXPECT_GT(r.pairs, 100);
    EXPECT_LT(off, 1.5);
    EXPECT_NEAR(r.time_offset_s * 1e3, -20.0, kTimeOffsetToleranceMs);
    // A scan over rows at several pitches turns about two axes, enough to pin the mounting down.
    std::printf("alignment from a scan: the mounting pinned to %.3f degrees about (%+.2f %+.2f %+.2f)\n",
                r.mounting_sd_deg, r.weakest_axis.x, r.weakest_axis.y, r.weakest_axis.z);
    EXPECT_NO_THROW(check_alignment_usable(r, "scan"));
}

TEST_F(SessionTest, AlignmentRecoversAPositiveTimeOffset) {
    // The other sign, and further out (the search covers +-50 ms): frames stamped 35 ms ahead,
    // with motion blur and a rolling shutter (the simulator's defaults). Before the alignment
    // turned each pair's rays to their frame's mid time, this scan put the offset at -8.0 ms.
    SimulateOptions o = alignment_scan(small_session(), 35);
    simulate_session(o);
    const Session s = open_session(dir_ / "session");
    EXPECT_DOUBLE_EQ(load_calibration(dir_ / "session" / "truth" / "calibration.json").time_offset_s, 0.035);
    const AlignmentResult r = calibrate_alignment(s);
    std::printf("alignment: true time offset +35 ms, estimated %+.1f ms (%d pairs)\n", r.time_offset_s * 1e3, r.pairs);
    EXPECT_GT(r.pairs, 100);
    EXPECT_NEAR(r.time_offset_s * 1e3, 35.0, kTimeOffsetToleranceMs);
}

// The calibration motion (`--trajectory alignment`: sweeps about yaw, pitch and roll in turn) at
// small frames: with turns about all three axes every axis of the mounting is observable, and
// the joint refinement finds the offset between the 1 ms grid's steps.
// The calibration motion of courtyard at 160x90, 4 fps, the sensor mounted -3 / 2.5 / 4 degrees
// (yaw / pitch / roll; the roll is about the optical axis: what a yaw scan could not see).
SimulateOptions three_axis_motion(SimulateOptions o) {
    o.env = std::string(GLINT_BLENDER_WORLDS) + "/courtyard.exr";
    o.trajectory = "alignment";
    o.width = 160;
    o.height = 90;
    o.fps = 4;
    o.mount_yaw_deg = -3.0;
    o.mount_pitch_deg = 2.5;
    o.mount_roll_deg = 4.0;
    return o;
}

TEST_F(SessionTest, AlignmentFromTheThreeAxisMotionFindsMountingAndOffset) {
    SimulateOptions o = three_axis_motion(small_session());
    o.time_offset_s = 0.0173;
    simulate_session(o);
    const Session s = open_session(dir_ / "session");
    const CameraCalibration truth = load_calibration(dir_ / "session" / "truth" / "calibration.json");
    const AlignmentResult r = calibrate_alignment(s);
    const double off = angle_between(r.sensor_from_camera, truth.sensor_from_camera) * 180 / kPi;
    std::printf("alignment motion: %d pairs, mounting off by %.3f degrees, time offset %.2f ms (true %.2f), "
                "median residual %.3f degrees\n",
                r.pairs, off, r.time_offset_s * 1e3, truth.time_offset_s * 1e3, r.residual_deg);
    EXPECT_GE(r.pairs, 20);  // 30 measured: small frames find features on fewer pairs
    EXPECT_LT(off, kThreeAxisMountingToleranceDeg);
    EXPECT_NEAR(r.time_offset_s * 1e3, 17.3, kThreeAxisTimeOffsetToleranceMs);
    std::printf("three-axis motion: the mounting pinned to %.3f degrees about its least-turned axis\n", r.mounting_sd_deg);
    EXPECT_NO_THROW(check_alignment_usable(r, "three axes"));
}

// The rolling shutter's readout from the calibration motion: a rolling shutter of 25 ms and a
// global one, the simulator's truth not read (the search starts from nothing). Measured at this
// size on three seeds: +0.4, +1.5 (global) and -1.1 ms; at 320x180 +0.1 to +2.7 ms on the three
// maps and readouts of 0-40 ms, +5 ms once (studio, seed 3, with motion blur).
TEST_F(SessionTest, ReadoutFromTheThreeAxisMotionFindsTheRollingShutter) {
    for (const double readout_ms : {25.0, 0.0}) {
        SimulateOptions o = three_axis_motion(small_session());
        o.readout_s = readout_ms * 1e-3;
        o.out = dir_ / ("readout-" + std::to_string(int(readout_ms)));
        simulate_session(o);
        Session s = open_session(o.out);
        s.calibration.readout_s = 0.010;  // a hand-entered value, neither of the truths
        const ReadoutResult r = calibrate_readout(s);
        std::printf("readout calibration: true %.1f ms, found %.2f ms (sd %.2f ms, %d pairs); offset %.2f ms\n",
                    readout_ms, r.readout_s * 1e3, r.sd_s * 1e3, r.pairs, r.alignment.time_offset_s * 1e3);
        EXPECT_NEAR(r.readout_s * 1e3, readout_ms, 4.0);
        EXPECT_LE(r.sd_s, kMaxReadoutSdS);
        EXPECT_GE(r.pairs, 15);
    }
}

// The calibration motion cut off after its first turns (the technician stopped, a recording
// lost): the image and sensor turns still agree (a median residual under 0.1 degrees), but about
// the axis they never turned away from the mounting is anything. It was written 13.6 degrees off.
TEST_F(SessionTest, AnAlignmentMotionCutShortIsNotPutInForce) {
    simulate_session(three_axis_motion(small_session()));
    // Only the frames of the first sweep (about one axis).
    const fs::path session = dir_ / "session";
    Session s = open_session(session);
    const std::vector<TruthPose> truth = load_truth_poses(s);
    ASSERT_EQ(truth.size(), s.frames.size());
    std::size_t keep = 1;
    while (keep < truth.size() && angle_between(truth[keep].world_from_camera, truth[0].world_from_camera) < kPi / 2 &&
           keep < s.frames.size() / 3)
        ++keep;
    s.frames.resize(keep);
    const AlignmentResult r = calibrate_alignment(s);
    std::printf("alignment motion cut to %zu frames: %d pairs, residual %.3f degrees, mounting pinned to %.2f "
                "degrees about (%+.2f %+.2f %+.2f)\n",
                keep, r.pairs, r.residual_deg, r.mounting_sd_deg, r.weakest_axis.x, r.weakest_axis.y, r.weakest_axis.z);
    EXPECT_GT(r.mounting_sd_deg, kMaxMountingSdDeg);
    EXPECT_THROW(check_alignment_usable(r, "cut"), InputError);
}

TEST_F(SessionTest, IntrinsicsFromChArUcoViewsMatchTheTrueCamera) {
    SimulateOptions o = small_session();
    o.width = 640;
    o.height = 360;
    ASSERT_EQ(simulate_charuco_session(o, 24), 24);
    const Session s = open_session(dir_ / "session");
    const IntrinsicsResult r = calibrate_intrinsics(s, {});
    const Intrinsics& k = r.intrinsics;
    const Intrinsics t = load_calibration(dir_ / "session" / "truth" / "calibration.json").intrinsics;
    // The lens as a whole: where both models put the same rays, over the image.
    double worst_px = 0;
    for (double v = 0; v < t.height; v += 20)
        for (double u = 0; u < t.width; u += 20) {
            const glm::dvec3 ray = pixel_ray(t, u, v);
            const auto p = project(k, ray, 50);
            ASSERT_TRUE(p) << u << "," << v;
            worst_px = std::max(worst_px, std::hypot(p->u - u, p->v - v));
        }
    std::printf("intrinsics: %d views, %d corners, RMS reprojection %.3f px; fx %.2f (true %.2f), cx %.2f (%.2f), "
                "cy %.2f (%.2f); the two lenses differ by at most %.3f px over the image\n",
                r.views, r.corners, r.rms_px, k.fx, t.fx, k.cx, t.cx, k.cy, t.cy, worst_px);
    EXPECT_GE(r.views, 12);
    EXPECT_LT(r.rms_px, 0.5);
    EXPECT_NEAR(k.fx / t.fx, 1.0, 0.01);
    EXPECT_NEAR(k.fy / t.fy, 1.0, 0.01);
    EXPECT_LT(worst_px, 2.5);  // at the image corners, which the views reach least (1.6 px with 32 views)
}

TEST(CalibrationIo, SensorLimitsAreOptionalAndRoundTrip) {
    // A file without "shortest_exposure_s" and "glare" (every file before 2026-12-02) reads as
    // no shortest exposure and no glare; with them, they come back; out of range is refused.
    CameraCalibration c;
    c.intrinsics = Intrinsics::from_fov(320, 180, 1.2);
    std::string text = calibration_to_json(c);
    const std::string old = std::regex_replace(
        std::regex_replace(text, std::regex(",\\s*\"shortest_exposure_s\": [0-9.e+-]+"), ""),
        std::regex(",\\s*\"glare\": \\{[^}]*\\}"), "");
    ASSERT_EQ(old.find("shortest_exposure_s"), std::string::npos);
    ASSERT_EQ(old.find("glare"), std::string::npos);
    const CameraCalibration plain = calibration_from_json(old, "old.json");
    EXPECT_EQ(plain.min_exposure_s, 0.0);
    EXPECT_EQ(plain.glare_fraction, 0.0);
    c.min_exposure_s = kModelledMinExposureS;
    c.glare_fraction = kModelledGlareFraction;
    c.glare_sigma_rad = kModelledGlareSigmaRad;
    text = calibration_to_json(c);
    const CameraCalibration back = calibration_from_json(text, "c.json");
    EXPECT_DOUBLE_EQ(back.min_exposure_s, kModelledMinExposureS);
    EXPECT_DOUBLE_EQ(back.glare_fraction, kModelledGlareFraction);
    EXPECT_DOUBLE_EQ(back.glare_sigma_rad, kModelledGlareSigmaRad);
    EXPECT_THROW(calibration_from_json(std::regex_replace(text, std::regex("\"fraction\": [0-9.e+-]+"),
                                                          "\"fraction\": -0.5"),
                                       "c.json"),
                 InputError);
    EXPECT_THROW(calibration_from_json(std::regex_replace(text, std::regex("\"shortest_exposure_s\": [0-9.e+-]+"),
                                                          "\"shortest_exposure_s\": 5"),
                                       "c.json"),
                 InputError);
    // A version beyond int's range is named as written (int(version) was undefined behaviour).
    try {
        calibration_from_json(std::regex_replace(text, std::regex("\"version\": 1"), "\"version\": 1e10"), "c.json");
        ADD_FAILURE() << "accepted version 1e10";
    } catch (const InputError& e) {
        EXPECT_NE(std::string(e.what()).find("c.json: key 'version': version 10000000000"), std::string::npos) << e.what();
    }
    // In range, but of no use inside the image (a sweep of bad inputs: a map 18x off, half the
    // coverage): a falloff that reaches 0, a distortion that cannot be undone at the corners.
    CameraCalibration dark = c;
    dark.vignetting = {-5, 0, 0};
    CameraCalibration warped = c;
    warped.intrinsics.k1 = -0.9;  // r (1 - 0.9 r^2) turns back at r = 0.61, short of the corner's 0.75
    for (const auto& [calibration, key] : {std::pair{dark, "key 'vignetting'"}, std::pair{warped, "key 'intrinsics.k1"}}) {
        try {
            calibration_from_json(calibration_to_json(calibration), "c.json");
            ADD_FAILURE() << "accepted " << key;
        } catch (const InputError& e) {
            EXPECT_NE(std::string(e.what()).find(std::string("c.json: ") + key), std::string::npos) << e.what();
        }
    }
    // Nor put in force by glint calibrate or the menu's wizards (the kiosk would not start on it).
    EXPECT_THROW(check_calibration_usable(warped, "calibration.json"), InputError);
    EXPECT_NO_THROW(check_calibration_usable(c, "calibration.json"));
    // Real lenses' barrel distortion and corner falloff read as written, a wide one too (90
    // degrees across 1920x1080 with k1 = -0.4, k2 = 0.2: its radial curve rises all the way,
    // though undistort's fixed point stops short at the corners).
    CameraCalibration lens = c;
    lens.intrinsics.k1 = -0.3;
    lens.intrinsics.k2 = 0.1;
    lens.vignetting = {-0.5, 0.1, 0};
    EXPECT_NO_THROW(calibration_from_json(calibration_to_json(lens), "c.json"));
    CameraCalibration wide = c;
    wide.intrinsics = Intrinsics::from_fov(1920, 1080, 90 * kPi / 180);
    wide.intrinsics.k1 = -0.4;
    wide.intrinsics.k2 = 0.2;
    EXPECT_NO_THROW(calibration_from_json(calibration_to_json(wide), "c.json"));
}

TEST(CalibrationIo, AMountingWrittenOnceReadsBackToTheSameText) {
    // A mounting quaternion a little off unit length (as a hand-edited file has it) is made unit
    // on reading; the file written from it must then read back to the same digits. Renormalising
    // a quaternion already unit can move its last bit, which tests/fuzz's calibration target
    // found with this quaternion.
    CameraCalibration c;
    c.intrinsics = Intrinsics::from_fov(320, 180, 1.2);
    c.sensor_from_camera = glm::dquat(0.9997541363709028, -0.01311637025514939, 0.017393650673189088,
                                      -0.004133830772909245) * 1.0004;
    const std::string once = calibration_to_json(calibration_from_json(calibration_to_json(c), "a.json"));
    const std::string twice = calibration_to_json(calibration_from_json(once, "b.json"));
    EXPECT_EQ(once, twice);
    // A run of such quaternions, each off unit length by up to 1e-4 either way.
    for (int i = 0; i < 200; ++i) {
        const double s = 1 + 1e-4 * std::sin(1.7 * i);
        c.sensor_from_camera = camera_look(0.37 * i, 0.11 * i - 5, 0.05 * i) * s;
        const std::string a = calibration_to_json(calibration_from_json(calibration_to_json(c), "a.json"));
        ASSERT_EQ(a, calibration_to_json(calibration_from_json(a, "b.json"))) << "quaternion " << i;
    }
}

TEST(CalibrationIo, RoundTripsAndRejectsBadValues) {
    CameraCalibration c;
    c.intrinsics = Intrinsics::from_fov(640, 480, 1.2);
    c.intrinsics.k1 = -0.1;
    c.vignetting = {-0.2, 0.01, 0};
    c.sensor_from_camera = camera_look(3, -2, 1);
    c.time_offset_s = 0.012;
    c.sensitivity = 42;
    const CameraCalibration back = calibration_from_json(calibration_to_json(c), "c.json");
    EXPECT_EQ(back.intrinsics.width, 640);
    EXPECT_DOUBLE_EQ(back.intrinsics.k1, -0.1);
    EXPECT_DOUBLE_EQ(back.vignetting.a1, -0.2);
    EXPECT_NEAR(angle_between(back.sensor_from_camera, c.sensor_from_camera), 0.0, 1e-9);
    EXPECT_DOUBLE_EQ(back.time_offset_s, 0.012);
    EXPECT_DOUBLE_EQ(back.response.inverse[200], c.response.inverse[200]);
    std::string text = calibration_to_json(c);
    const std::string bad = std::regex_replace(text, std::regex("\"fx\": [0-9.e+-]+"), "\"fx\": -3");
    EXPECT_THROW(calibration_from_json(bad, "c.json"), InputError);
    EXPECT_THROW(calibration_from_json("{", "c.json"), InputError);
    // A number beyond double's range: nlohmann throws out_of_range, not parse_error (found by
    // tests/fuzz's calibration target).
    EXPECT_THROW(calibration_from_json(std::regex_replace(text, std::regex("\"fx\": [0-9.e+-]+"), "\"fx\": 1e999"),
                                       "c.json"),
                 InputError);
    // A version beyond int's range is named as written (int(version) was undefined behaviour).
    try {
        calibration_from_json(std::regex_replace(text, std::regex("\"version\": 1"), "\"version\": 1e10"), "c.json");
        ADD_FAILURE() << "accepted version 1e10";
    } catch (const InputError& e) {
        EXPECT_NE(std::string(e.what()).find("c.json: key 'version': version 10000000000"), std::string::npos) << e.what();
    }
}

}  // namespace
}  // namespace glint::capture
