// The maintenance menu's calibration wizards (appliance/app/calibration_wizard.hpp) fed simulated
// sessions frame by frame, as the kiosk loop feeds them: each must keep the frames that serve,
// finish by itself, and find the simulator's true camera within the calibrations' own tolerances
// (tests/capture/test_session.cpp states them for `glint calibrate`).
#include <gtest/gtest.h>

#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>

#include "appliance/app/calibration_wizard.hpp"
#include "appliance/capture/calibration_io.hpp"
#include "appliance/capture/calibration_truth.hpp"
#include "appliance/capture/capture_pipeline.hpp"
#include "appliance/capture/session.hpp"
#include "appliance/core/exr_io.hpp"
#include "appliance/core/hdr_image.hpp"
#include "appliance/core/rotation.hpp"
#include "appliance/sim/session_simulator.hpp"

namespace glint::app {
namespace {

namespace fs = std::filesystem;
using ui::CalibrationKind;
constexpr double kPi = 3.14159265358979323846;

class WizardTest : public ::testing::Test {
protected:
    void SetUp() override {
        dir_ = fs::temp_directory_path() / ("glint-wizard-test-" + std::to_string(::getpid()));
        fs::remove_all(dir_);
        fs::create_directories(dir_);
    }
    void TearDown() override { fs::remove_all(dir_); }

    WizardSettings settings() const {
        WizardSettings s;
        s.sessions_dir = dir_ / "runs";
        s.never_drop = true;
        return s;
    }
    sim::SimulateOptions options(const std::string& env = "courtyard.exr") const {
        sim::SimulateOptions o;
        o.env = std::string(GLINT_BLENDER_WORLDS) + "/" + env;
        o.out = dir_ / "session";
        o.fps = 1.0;
        o.width = 96;
        o.height = 54;
        o.threads = 2;
        return o;
    }

    // The session's frames one a poll, with the orientations up to each frame's time, as the
    // kiosk loop hands them over; then waits until the wizard has finished (or can do no more).
    static void play(CalibrationWizard& wizard, const capture::Session& s) {
        const std::vector<capture::SensorOrientation> sensors =
            s.sensors.empty() ? std::vector<capture::SensorOrientation>{} : capture::load_sensor_orientations(s);
        std::size_t next = 0;
        for (const capture::FrameRecord& r : s.frames) {
            ui::KioskPoll poll;
            for (; next < sensors.size() && sensors[next].t_ns <= r.t_ns; ++next) poll.orientations.push_back(sensors[next]);
            poll.frames.push_back(capture::load_frame(s, r));
            wizard.feed(poll);
        }
        for (int k = 0; k < 1000 && wizard.view().running; ++k) {
            wizard.wait_idle();
            if (!wizard.view().computing) break;
        }
    }

    fs::path dir_;
};

std::vector<std::string> log_lines;
void log_line(const std::string& line) { log_lines.push_back(line); }

TEST_F(WizardTest, CameraIntrinsicsFromBoardViewsFindTheTrueLens) {
    sim::SimulateOptions o = options();
    o.width = 640;
    o.height = 360;
    ASSERT_EQ(sim::simulate_charuco_session(o, 24), 24);
    const capture::Session s = capture::open_session(o.out);
    CalibrationWizard wizard(settings(), s.calibration, log_line);
    wizard.start(CalibrationKind::CameraIntrinsics, "t1");
    EXPECT_TRUE(wizard.view().running);
    EXPECT_FALSE(wizard.result());
    play(wizard, s);
    const WizardView v = wizard.view();
    ASSERT_FALSE(v.running) << v.step;
    ASSERT_TRUE(v.can_apply) << v.result;
    std::printf("intrinsics wizard: %s\n", v.result.c_str());
    EXPECT_NE(v.result.find("RMS reprojection error"), std::string::npos);
    const capture::Intrinsics k = wizard.result()->intrinsics;
    const capture::Intrinsics t = capture::load_calibration(o.out / "truth" / "calibration.json").intrinsics;
    EXPECT_NEAR(k.fx / t.fx, 1, 0.01);
    EXPECT_NEAR(k.fy / t.fy, 1, 0.01);
    EXPECT_NEAR(k.cx, t.cx, 5);
    EXPECT_NEAR(k.cy, t.cy, 5);
    // The run is a session `glint calibrate` reads: 12 views kept, out of the 24 offered.
    const capture::Session run = capture::open_session(dir_ / "runs" / "camera-t1");
    EXPECT_EQ(run.frames.size(), 12u);
    // The preview shows the frames, downscaled to the preview's width.
    WizardPreview preview;
    ASSERT_TRUE(wizard.preview_since(preview));
    EXPECT_EQ(preview.width, 480);
    EXPECT_EQ(preview.height, 270);
    EXPECT_EQ(preview.rgba.size(), std::size_t(480 * 270 * 4));
    EXPECT_FALSE(wizard.preview_since(preview));  // nothing newer
}

TEST_F(WizardTest, TheSameViewAgainIsNotANewView) {
    sim::SimulateOptions o = options();
    o.width = 640;
    o.height = 360;
    ASSERT_EQ(sim::simulate_charuco_session(o, 4), 4);
    const capture::Session s = capture::open_session(o.out);
    CalibrationWizard wizard(settings(), s.calibration, log_line);
    wizard.start(CalibrationKind::CameraIntrinsics, "same");
    capture::CameraFrame f = capture::load_frame(s, s.frames[0]);
    for (int k = 0; k < 10; ++k) {
        ui::KioskPoll poll;
        f.t_ns = std::int64_t(k + 1) * 1'000'000'000;  // far apart in time: only the place counts
        poll.frames.push_back(f);
        wizard.feed(poll);
    }
    wizard.wait_idle();
    const WizardView v = wizard.view();
    EXPECT_TRUE(v.running);
    EXPECT_NE(v.step.find("(1 of 12 views)"), std::string::npos) << v.step;
    EXPECT_NE(v.step.find("new place"), std::string::npos) << v.step;
    wizard.cancel();
    EXPECT_FALSE(wizard.view().running);
    EXPECT_EQ(wizard.view().result, "cancelled");
    EXPECT_FALSE(wizard.result());
}

TEST_F(WizardTest, ResponseAsksForTheBracketAndFindsTheTrueCurve) {
    sim::SimulateOptions o = options();
    o.bracket = 12;
    o.bracket_first_exposure_s = 2e-5;
    o.camera_noise = false;
    sim::simulate_session(o);
    const capture::Session s = capture::open_session(o.out);
    WizardSettings ws = settings();
    CalibrationWizard wizard(ws, s.calibration, log_line);
    wizard.start(CalibrationKind::Response, "r");
    EXPECT_FALSE(wizard.exposure_request());  // nothing seen yet: the camera's own exposure
    // The first frame sets the middle of the ladder; the wizard asks for 2^-5 of it first.
    ui::KioskPoll first;
    first.frames.push_back(capture::load_frame(s, s.frames[0]));
    const double e0 = first.frames[0].exposure_s * first.frames[0].total_gain();
    wizard.feed(first);
    wizard.wait_idle();
    const auto asked = wizard.exposure_request();
    ASSERT_TRUE(asked);
    EXPECT_FALSE(asked->automatic);
    EXPECT_NEAR(asked->exposure_s, e0 / 32, e0 * 1e-9);
    // The rest of the recorded bracket (a replay cannot set exposures: it takes what is there).
    capture::Session rest = s;
    rest.frames.erase(rest.frames.begin());
    play(wizard, rest);
    const WizardView v = wizard.view();
    ASSERT_FALSE(v.running) << v.step;
    ASSERT_TRUE(v.can_apply) << v.result;
    std::printf("response wizard: %s\n", v.result.c_str());
    EXPECT_FALSE(wizard.exposure_request());  // the camera's own exposure again
    const capture::Response r = wizard.result()->response;
    const capture::Response t = capture::load_calibration(o.out / "truth" / "calibration.json").response;
    double worst = 0;
    for (int z = 64; z <= 250; ++z)
        worst = std::max(worst, std::abs((r.inverse[std::size_t(z)] / r.inverse[128]) / (t.inverse[std::size_t(z)] / t.inverse[128]) - 1));
    EXPECT_LT(worst, 0.05);
    // A noiseless bracket shows no shot noise: the noise model in force is kept, and the result
    // says so beside the new curve.
    EXPECT_NE(v.result.find("noise model kept"), std::string::npos) << v.result;
    EXPECT_EQ(wizard.result()->noise_full_well_electrons, s.calibration.noise_full_well_electrons);
    EXPECT_EQ(wizard.result()->noise_read, s.calibration.noise_read);
}

TEST_F(WizardTest, ResponseRunAlsoFindsTheSensorsNoiseFromItsBracket) {
    // A noisy bracket, long enough for the curve (16 exposures from 20 us; a short one leaves the
    // curve tens of per cent off, and the noise model with it: docs/capture.md, "Calibration").
    sim::SimulateOptions o = options();
    o.width = 240;
    o.height = 135;
    o.bracket = 16;
    o.bracket_first_exposure_s = 2e-5;
    sim::simulate_session(o);
    const capture::Session s = capture::open_session(o.out);
    WizardSettings ws = settings();
    ws.bracket_frames = 16;
    capture::CameraCalibration in_force = s.calibration;
    in_force.noise_full_well_electrons = 0;  // no model yet
    in_force.noise_read = 0;
    CalibrationWizard wizard(ws, in_force, log_line);
    wizard.start(CalibrationKind::Response, "noisy");
    play(wizard, s);
    const WizardView v = wizard.view();
    ASSERT_FALSE(v.running) << v.step;
    ASSERT_TRUE(v.can_apply) << v.result;
    std::printf("response wizard, noisy bracket: %s\n", v.result.c_str());
    EXPECT_NE(v.result.find("noise: full well"), std::string::npos) << v.result;
    const std::optional<capture::CameraCalibration> result = wizard.result();
    ASSERT_TRUE(result);
    const capture::CameraCalibration& r = *result;
    ASSERT_GT(r.noise_full_well_electrons, 0);
    ASSERT_GT(r.noise_read, 0);
    // Against the truth on the truth's response scale (the fitted curve's scale is its own).
    const capture::NoiseError e = capture::noise_error_against_truth(r.noise_full_well_electrons, r.noise_read,
                                                                      r.response, capture::truth_calibration(s));
    std::printf("noise against the truth: full well %+.1f %%, read noise %+.1f %%\n", 100 * e.full_well,
                100 * e.read_noise);
    EXPECT_LT(std::abs(e.full_well), 0.1);
    EXPECT_LT(std::abs(e.read_noise), 0.1);
}

TEST_F(WizardTest, BracketConsistencyIsSmallWithTheTrueCurveAndLargeWithAWrongOne) {
    // Two frames of one view, 4x apart in exposure, made through the parametric curve.
    const capture::Response truth = capture::Response::parametric();
    cv::Mat a(32, 32, CV_8UC3), b(32, 32, CV_8UC3);
    for (int v = 0; v < 32; ++v)
        for (int u = 0; u < 32; ++u) {
            const double x = 0.002 + 0.25 * (u + 32 * v) / 1024.0;  // relative exposure at 1 s
            for (int c = 0; c < 3; ++c) {
                a.at<cv::Vec3b>(v, u)[c] = cv::saturate_cast<std::uint8_t>(truth.forward(x * 1.0));
                b.at<cv::Vec3b>(v, u)[c] = cv::saturate_cast<std::uint8_t>(truth.forward(x * 4.0));
            }
        }
    const double right = bracket_consistency({a, b}, {1.0, 4.0}, truth.inverse);
    capture::Response linear;
    for (int z = 0; z < 256; ++z) linear.inverse[std::size_t(z)] = (z + 0.5) / 255.0;
    const double wrong = bracket_consistency({a, b}, {1.0, 4.0}, linear.inverse);
    EXPECT_GE(right, 0);
    EXPECT_LT(right, 0.03);
    EXPECT_GT(wrong, 0.2);
}

TEST_F(WizardTest, VignettingFromAFlatFieldFindsTheTrueFalloff) {
    // A uniform grey world seen by a still camera: every frame a flat field.
    HdrImage flat(64, 32);
    for (int j = 0; j < 32; ++j)
        for (int i = 0; i < 64; ++i) flat.set(i, j, {0.5f, 0.5f, 0.5f});
    save_exr(dir_ / "flat.exr", flat);
    sim::SimulateOptions o = options();
    o.env = dir_ / "flat.exr";
    o.trajectory = (dir_ / "still.csv").string();
    std::ofstream(dir_ / "still.csv") << "0,1,0,0,0\n5,1,0,0,0\n";
    o.fps = 2;
    sim::simulate_session(o);
    const capture::Session s = capture::open_session(o.out);
    CalibrationWizard wizard(settings(), s.calibration, log_line);
    wizard.start(CalibrationKind::Vignetting, "v");
    play(wizard, s);
    const WizardView v = wizard.view();
    ASSERT_FALSE(v.running) << v.step;
    ASSERT_TRUE(v.can_apply) << v.result;
    std::printf("vignetting wizard: %s\n", v.result.c_str());
    const capture::Vignetting r = wizard.result()->vignetting;
    const capture::Vignetting t = capture::load_calibration(o.out / "truth" / "calibration.json").vignetting;
    double worst = 0;
    for (double rr = 0; rr <= 1.0; rr += 0.05) {
        const double r2 = rr * rr;
        const auto at = [&](const capture::Vignetting& g) { return 1 + r2 * (g.a1 + r2 * (g.a2 + r2 * g.a3)); };
        worst = std::max(worst, std::abs(at(r) - at(t)));
    }
    EXPECT_LT(worst, 0.01);  // as `glint calibrate vignetting` (test_session.cpp)
}

TEST_F(WizardTest, VignettingRefusesAClippedView) {
    CalibrationWizard wizard(settings(), capture::CameraCalibration{}, log_line);
    wizard.start(CalibrationKind::Vignetting, "clipped");
    ui::KioskPoll poll;
    capture::CameraFrame f;
    f.rgb = cv::Mat(54, 96, CV_8UC3, cv::Scalar(255, 255, 255));
    f.t_ns = 1'000'000'000;
    f.exposure_s = 0.01;
    poll.frames.push_back(f);
    wizard.feed(poll);
    wizard.wait_idle();
    const WizardView v = wizard.view();
    EXPECT_NE(v.step.find("(0 of 8 frames)"), std::string::npos) << v.step;
    EXPECT_NE(v.step.find("too bright"), std::string::npos) << v.step;
}

TEST_F(WizardTest, AlignmentFollowsTheThreeAxisMotionAndFindsTheMounting) {
    sim::SimulateOptions o = options();
    o.trajectory = "alignment";
    o.width = 160;
    o.height = 90;
    o.fps = 4;
    o.mount_yaw_deg = -3.0;
    o.mount_pitch_deg = 2.5;
    o.mount_roll_deg = 4.0;
    o.time_offset_s = 0.0173;
    sim::simulate_session(o);
    const capture::Session s = capture::open_session(o.out);
    capture::CameraCalibration in_force = s.calibration;
    in_force.readout_s = 0.010;  // hand-entered, off the simulator's 20 ms
    CalibrationWizard wizard(settings(), in_force, log_line);
    wizard.start(CalibrationKind::Alignment, "a");
    play(wizard, s);
    const WizardView v = wizard.view();
    ASSERT_FALSE(v.running) << v.step;
    ASSERT_TRUE(v.can_apply) << v.result;
    std::printf("alignment wizard: %s\n", v.result.c_str());
    const capture::CameraCalibration truth = capture::load_calibration(o.out / "truth" / "calibration.json");
    const capture::CameraCalibration r = *wizard.result();
    // The tolerances of `glint calibrate alignment` on this motion (test_session.cpp).
    EXPECT_LT(angle_between(r.sensor_from_camera, truth.sensor_from_camera) * 180 / kPi, 0.5);
    EXPECT_NEAR(r.time_offset_s * 1e3, 17.3, 3.0);
    // The readout from the same motion (`glint calibrate readout`'s tolerance, test_session.cpp).
    EXPECT_NE(v.result.find("readout"), std::string::npos) << v.result;
    EXPECT_NEAR(r.readout_s * 1e3, truth.readout_s * 1e3, 4.0);
}

TEST_F(WizardTest, TurnsCountOnlyAboutTheAxisTheyAreAbout) {
    // A pan of 70 degrees with the sensor's jitter (0.05 degrees a sample at 200 Hz): the pan
    // counts, the jitter adds nothing to tilt or roll, and a wobble under 2 degrees nothing at all.
    CalibrationWizard wizard(settings(), capture::CameraCalibration{}, log_line);
    wizard.start(CalibrationKind::Alignment, "turns");
    ui::KioskPoll poll;
    for (int k = 0; k <= 1400; ++k) {
        const double yaw = 0.05 * k * kPi / 180, jitter = 0.05 * ((k % 2) ? 1 : -1) * kPi / 180;
        const glm::dquat q = glm::angleAxis(yaw, glm::dvec3(0, 1, 0)) * glm::angleAxis(jitter, glm::dvec3(1, 0, 0)) *
                             glm::angleAxis(jitter, glm::dvec3(0, 0, 1));
        poll.orientations.push_back({std::int64_t(k) * 5'000'000, q});
    }
    wizard.feed(poll);
    const WizardView v = wizard.view();
    ASSERT_TRUE(v.running);
    EXPECT_NE(v.step.find("Pan 60, tilt 0, roll 0 of 60 degrees"), std::string::npos) << v.step;
    EXPECT_NE(v.step.find("Tilt the camera"), std::string::npos) << v.step;
    EXPECT_NEAR(v.progress, 1.0 / 3, 1e-9);
}

}  // namespace
}  // namespace glint::app
