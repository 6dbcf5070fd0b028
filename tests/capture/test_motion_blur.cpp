// Motion blur and the rolling shutter (docs/capture.md "Camera simulator", "Rolling shutter",
// "Blurred frames"): the simulator integrates each pixel over its exposure along the camera's path
// and reads its rows out over the calibration's readout_s; the accumulators turn each row by the
// angular velocity x its time; the pipeline leaves out frames blurred beyond a limit.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <regex>
#include <unistd.h>

#include "appliance/capture/calibration_io.hpp"
#include "appliance/capture/capture_pipeline.hpp"
#include "appliance/capture/hdr_accumulator.hpp"
#include "appliance/capture/replay_camera.hpp"
#include "appliance/capture/session.hpp"
#include "appliance/core/equirect.hpp"
#include "appliance/core/errors.hpp"
#include "appliance/core/exr_io.hpp"
#include "appliance/sim/camera_simulator.hpp"
#include "appliance/sim/session_simulator.hpp"

namespace glint::capture {
namespace {

namespace fs = std::filesystem;
using sim::AutoExposureModel;
using sim::camera_look;
using sim::CameraPath;
using sim::CameraSimulator;
using sim::SensorModel;

constexpr double kDeg = kPi / 180.0;

SensorModel noiseless() {
    SensorModel s;
    s.noise = false;
    return s;
}

AutoExposureModel manual() {
    AutoExposureModel m;
    m.enabled = false;
    return m;
}

// A pinhole without distortion or vignetting, so that pixels and angles relate simply.
CameraCalibration plain_camera(int width, int height, double fov_deg, double readout_s) {
    CameraCalibration cal;
    cal.intrinsics = Intrinsics::from_fov(width, height, fov_deg * kDeg);
    cal.sensitivity = 6.0e5 / 6000;
    cal.readout_s = readout_s;
    return cal;
}

// Yawing left at `deg_s` about world +Y through the horizon, yaw 0 at the frame's time.
CameraPath yawing(double deg_s) {
    return [deg_s](double offset_s) { return camera_look(deg_s * offset_s, 0); };
}

// Linear exposure of a frame's green channel (the response inverted; no vignetting here).
cv::Mat linear(const CameraFrame& f, const CameraCalibration& cal) {
    cv::Mat x(f.rgb.rows, f.rgb.cols, CV_64F);
    for (int v = 0; v < f.rgb.rows; ++v)
        for (int u = 0; u < f.rgb.cols; ++u) {
            const int z = f.rgb.at<cv::Vec3b>(v, u)[1];
            EXPECT_LT(z, 255) << "clipped at " << u << "," << v;
            x.at<double>(v, u) = z > 0 ? cal.response.inverse[std::size_t(z)] : 0.0;
        }
    return x;
}

TEST(MotionBlur, AStillCameraRendersTheFrameOfItsOneOrientation) {
    // A textured sky, noise on: a path that does not move must give the very frame of render(q)
    // (one time sample per pixel, the 2x2 rays of before), rolling shutter or not.
    HdrImage env(256, 128);
    for (int j = 0; j < 128; ++j)
        for (int i = 0; i < 256; ++i) {
            const double l = 0.5 + 0.4 * std::sin(0.3 * i) * std::cos(0.2 * j);
            env.set(i, j, {float(l), float(0.8 * l), float(0.6 * l)});
        }
    CameraCalibration cal = plain_camera(160, 90, 70, 0.020);
    cal.intrinsics.k1 = -0.08;
    CameraSimulator a(env, cal, SensorModel{}, AutoExposureModel{}, 5), b(env, cal, SensorModel{}, AutoExposureModel{}, 5);
    const glm::dquat q = camera_look(30, 10);
    for (int k = 0; k < 3; ++k) {
        const CameraFrame fa = a.render(q, k, 2);
        const CameraFrame fb = b.render([&](double) { return q; }, k, 2);
        EXPECT_EQ(b.time_samples([&](double) { return q; }, 0), 1);
        EXPECT_EQ(cv::norm(fa.rgb, fb.rgb, cv::NORM_INF), 0.0) << "frame " << k;
    }
    // A camera turning by a fifth of a pixel over the exposure is still one sample.
    const double px_rad = 70 * kDeg / 160;
    EXPECT_EQ(b.time_samples(yawing(0.2 * px_rad / kDeg / b.exposure_s()), 45), 1);
}

TEST(MotionBlur, AMovingCameraSmearsAPointSourceByThePredictedLength) {
    // A source of about two pixels straight ahead (the four texels round the view axis), the camera yawing at 90 deg/s through a 1/30 s
    // exposure: a streak of angular speed x exposure x focal length pixels along the rows.
    HdrImage env(1024, 512);
    for (int j = 0; j < 512; ++j)
        for (int i = 0; i < 1024; ++i)
            env.set(i, j, glm::dot(texel_direction(i, j, 1024, 512), glm::dvec3(0, 0, -1)) > std::cos(0.3 * kDeg)
                              ? Rgb{0.2f, 0.2f, 0.2f}
                              : Rgb{0, 0, 0});
    const CameraCalibration cal = plain_camera(160, 90, 60, 0);
    const double exposure = 1.0 / 30, speed = 90;
    const auto streak = [&](double deg_s, int& rows) {
        CameraSimulator sim(env, cal, noiseless(), manual());
        sim.set_exposure(exposure, 1);
        const cv::Mat x = linear(sim.render(yawing(deg_s), 0, 2), cal);
        // Length along the rows: the column profile's sum over its peak (a box of length L
        // smoothed by less than L keeps its height, so this is L); rows lit: the spread across.
        std::vector<double> columns(std::size_t(x.cols), 0.0);
        rows = 0;
        for (int v = 0; v < x.rows; ++v) {
            double row = 0;
            for (int u = 0; u < x.cols; ++u) {
                columns[std::size_t(u)] += x.at<double>(v, u);
                row += x.at<double>(v, u);
            }
            rows += row > 1e-3;
        }
        double sum = 0, peak = 0;
        for (double c : columns) {
            sum += c;
            peak = std::max(peak, c);
        }
        return sum / peak;
    };
    int rows_still = 0, rows_moving = 0;
    const double still = streak(0, rows_still);
    const double moving = streak(speed, rows_moving);
    const double predicted = speed * kDeg * exposure * cal.intrinsics.fx;  // 7.3 px
    std::printf("point source: %.2f px long still, %.2f px at %.0f deg/s (predicted %.2f); %d and %d rows lit\n", still,
                moving, speed, predicted, rows_still, rows_moving);
    EXPECT_LT(still, 3.0);
    EXPECT_NEAR(moving, predicted, 0.1 * predicted);
    // Along the motion only: no more rows than the still source lights.
    EXPECT_LE(rows_moving, rows_still);
}

// A meridian of light (3 texels of 0.18 degrees wide) straight ahead, from -40 to 40 degrees of
// elevation, on a dim sky.
HdrImage meridian() {
    HdrImage env(2048, 1024);
    for (int j = 0; j < 1024; ++j)
        for (int i = 0; i < 2048; ++i) {
            const double elevation = 90 - row_theta(j, 1024) / kDeg;
            const bool line = std::abs(column_phi(i, 2048)) < 0.27 * kDeg && std::abs(elevation) < 40;
            env.set(i, j, line ? Rgb{5, 5, 5} : Rgb{0.05f, 0.05f, 0.05f});
        }
    return env;
}

// Centroid column of the bright line in each row of a linear frame or map, where it is found.
std::vector<std::pair<int, double>> line_centroids(const std::function<double(int, int)>& value, int cols, int rows,
                                                   double background) {
    std::vector<std::pair<int, double>> out;
    for (int v = 0; v < rows; ++v) {
        double sum = 0, moment = 0;
        for (int u = 0; u < cols; ++u) {
            const double x = std::max(0.0, value(u, v) - 3 * background);
            sum += x;
            moment += x * u;
        }
        if (sum > 0) out.push_back({v, moment / sum});
    }
    return out;
}

// Least-squares slope of centroid column over row.
double slope(const std::vector<std::pair<int, double>>& c) {
    double n = 0, sv = 0, su = 0, svv = 0, svu = 0;
    for (const auto& [v, u] : c) {
        n += 1;
        sv += v;
        su += u;
        svv += double(v) * v;
        svu += v * u;
    }
    return (n * svu - sv * su) / (n * svv - sv * sv);
}

// The rolling-shutter tests' frame: the meridian line, yawing left at 90 deg/s, a 30 ms readout
// and a 0.1 ms exposure (no blur).
struct LeaningFrame {
    HdrImage env = meridian();
    CameraCalibration cal = plain_camera(160, 120, 60, 0.030);
    double speed = 90;  // deg/s
    CameraFrame frame;
};
LeaningFrame leaning_frame() {
    LeaningFrame l;
    CameraSimulator sim(l.env, l.cal, noiseless(), manual());
    sim.set_exposure(1e-4, 1);
    l.frame = sim.render(yawing(l.speed), 0, 2);
    return l;
}

TEST(MotionBlur, TheRollingShutterShiftsEachRowByTheTurnSinceTheMiddleRow) {
    // Yawing left at 90 deg/s with a 30 ms readout and a 0.1 ms exposure (no blur): row v is
    // exposed 30 ms x (v - 59.5) / 120 after the middle row, when the world has moved right by the
    // turn since, so a vertical line leans by fx x speed x readout / height pixels per row.
    const LeaningFrame l = leaning_frame();
    const HdrImage& env = l.env;
    const CameraCalibration& cal = l.cal;
    const double speed = l.speed;
    const CameraFrame& f = l.frame;
    const cv::Mat x = linear(f, cal);
    const double background = 0.05 * 1e-4 * 100;
    const auto c = line_centroids([&](int u, int v) { return x.at<double>(v, u); }, x.cols, x.rows, background);
    ASSERT_GT(c.size(), 100u);
    const double predicted = cal.intrinsics.fx * speed * kDeg * cal.readout_s / cal.intrinsics.height;
    const double got = slope(c);
    std::printf("rolling shutter: %.5f px per row (predicted %.5f)\n", got, predicted);
    EXPECT_NEAR(got, predicted, 0.05 * predicted);
    // The middle row's time is the frame's: the line passes the centre there.
    for (const auto& [v, u] : c)
        if (v == 59 || v == 60) {
            EXPECT_NEAR(u, cal.intrinsics.cx + (v - 59.5) * predicted, 0.15);
        }
    // A global shutter (readout 0): upright.
    CameraSimulator global(env, plain_camera(160, 120, 60, 0), noiseless(), manual());
    global.set_exposure(1e-4, 1);
    const cv::Mat g = linear(global.render(yawing(speed), 0, 2), cal);
    EXPECT_NEAR(slope(line_centroids([&](int u, int v) { return g.at<double>(v, u); }, g.cols, g.rows, background)), 0.0,
                0.002);
}

TEST(MotionBlur, TheAccumulatorTurnsEachRowBackIntoPlace) {
    // The leaning frame above, accumulated with the frame's orientation and the angular velocity:
    // the line stands upright on the sphere again. Without the angular velocity it leans as in
    // the frame (6.5 pixels over the frame, 0.37 degrees each: about 7 texels at 1024x512).
    const LeaningFrame l = leaning_frame();
    const CameraCalibration& cal = l.cal;
    const double speed = l.speed;
    const CameraFrame& f = l.frame;
    const glm::dvec3 w(0, speed * kDeg, 0);  // camera frame: yaw about the camera's +Y (up)
    const auto lean = [&](const glm::dvec3& angular_velocity) {
        HdrAccumulator acc(1024, 512);
        acc.add_frame(f, cal, camera_look(0, 0), 2, angular_velocity);
        const HdrImage m = acc.radiance();
        const auto c = line_centroids(
            [&](int i, int j) {
                return acc.samples()[std::size_t(j) * 1024 + std::size_t(i)] > 0 && std::abs(i - 511.5) < 40
                           ? double(m.at(i, j).g)
                           : 0.0;
            },
            1024, 512, 0.05);
        EXPECT_GT(c.size(), 80u);
        return c.empty() ? 0.0 : c.back().second - c.front().second;
    };
    const double corrected = lean(w), uncorrected = lean(glm::dvec3(0));
    std::printf("the line on the sphere leans %.2f texels top to bottom corrected, %.2f uncorrected\n", corrected,
                uncorrected);
    EXPECT_GT(std::abs(uncorrected), 5.0);
    EXPECT_LT(std::abs(corrected), 0.6);
}

TEST(MotionBlur, ADeskewedFrameIsWhatAGlobalShutterSaw) {
    // A textured sky, the camera turning about all three axes at 60 deg/s, a 30 ms readout, a
    // 0.1 ms exposure: the rolling-shutter frame resampled with the angular velocity must be the
    // global shutter's frame at the frame's time (up to the bilinear resampling), far closer than
    // the rolling-shutter frame itself.
    HdrImage env(1024, 512);
    for (int j = 0; j < 512; ++j)
        for (int i = 0; i < 1024; ++i) {
            const double l = 2 + 1.5 * std::sin(0.21 * i) * std::cos(0.17 * j) + 0.5 * std::sin(0.05 * i + 0.03 * j);
            env.set(i, j, {float(l), float(0.8 * l), float(0.6 * l)});
        }
    CameraCalibration cal = plain_camera(160, 120, 60, 0.030);
    cal.intrinsics.k1 = -0.08;
    const glm::dquat start = camera_look(20, -30, 5);
    const glm::dvec3 w = glm::normalize(glm::dvec3(0.3, 1.0, -0.6)) * (60 * kDeg);  // camera frame
    const CameraPath path = [&](double t) { return start * rotation_from_vector(w * t); };
    const auto render = [&](double readout) {
        CameraCalibration c = cal;
        c.readout_s = readout;
        CameraSimulator sim(env, c, noiseless(), manual());
        sim.set_exposure(2e-3, 1);
        return sim.render(path, 0, 2);
    };
    const CameraFrame rolling = render(cal.readout_s), global = render(0);
    std::vector<glm::dvec3> rays;
    for (int v = 0; v < 120; ++v)
        for (int u = 0; u < 160; ++u) rays.push_back(pixel_ray(cal.intrinsics, u, v));
    const CameraFrame straight = deskew_rolling_shutter(rolling, cal, rays, w, 2);
    const auto mean_difference = [&](const CameraFrame& a) {
        double sum = 0;
        int n = 0;
        for (int v = 8; v < 112; ++v)
            for (int u = 8; u < 152; ++u) {
                sum += std::abs(int(a.rgb.at<cv::Vec3b>(v, u)[1]) - int(global.rgb.at<cv::Vec3b>(v, u)[1]));
                ++n;
            }
        return sum / n;
    };
    const double before = mean_difference(rolling), after = mean_difference(straight);
    std::printf("mean code difference from the global shutter's frame: %.2f rolling, %.2f deskewed\n", before, after);
    EXPECT_LT(after, 0.25 * before);
}

TEST(MotionBlur, CalibrationKeepsTheReadoutAndOldFilesHaveAGlobalShutter) {
    CameraCalibration c;
    c.intrinsics = Intrinsics::from_fov(320, 180, 1.2);
    c.readout_s = kModelledReadoutS;
    const std::string text = calibration_to_json(c);
    EXPECT_DOUBLE_EQ(calibration_from_json(text, "c.json").readout_s, kModelledReadoutS);
    // A file written before the key existed: a global shutter, which is what it was made with.
    const std::string old = std::regex_replace(text, std::regex(",\\s*\"readout_s\": [0-9.e+-]+"), "");
    ASSERT_EQ(old.find("readout_s"), std::string::npos);
    EXPECT_EQ(calibration_from_json(old, "old.json").readout_s, 0.0);
    try {
        calibration_from_json(std::regex_replace(text, std::regex("\"readout_s\": [0-9.e+-]+"), "\"readout_s\": -0.01"),
                              "c.json");
        ADD_FAILURE() << "a negative readout time was accepted";
    } catch (const InputError& e) {
        EXPECT_NE(std::string(e.what()).find("readout_s"), std::string::npos) << e.what();
    }
    // Row times: the middle of the frame is the frame's time, the rows readout_s / height apart.
    EXPECT_DOUBLE_EQ(c.row_time_offset_s(89.5), 0.0);
    EXPECT_NEAR(c.row_time_offset_s(179) - c.row_time_offset_s(0), kModelledReadoutS * 179 / 180, 1e-15);
}

class BlurredFrames : public ::testing::Test {
protected:
    void SetUp() override {
        dir_ = fs::temp_directory_path() / ("glint-motion-blur-test-" + std::to_string(::getpid()));
        fs::remove_all(dir_);
        fs::create_directories(dir_);
        // A dim room (the auto-exposure goes to its longest exposure, 1/30 s) ...
        HdrImage env(128, 64);
        for (int j = 0; j < 64; ++j)
            for (int i = 0; i < 128; ++i) {
                const double l = 0.04 * (1 + 0.5 * std::sin(0.4 * i) * std::cos(0.3 * j));
                env.set(i, j, {float(l), float(l), float(l)});
            }
        save_exr(dir_ / "env.exr", env);
        // ... and a camera that turns at 90 deg/s for 2 s, then holds still for 2 s.
        std::ofstream t(dir_ / "turn.csv");
        for (int k = 0; k <= 40; ++k) {
            const double s = std::min(k, 20) * 0.1, yaw = 90 * s * kDeg;
            t << k * 0.1 << "," << std::cos(yaw / 2) << ",0," << std::sin(yaw / 2) << ",0\n";
        }
    }
    void TearDown() override { fs::remove_all(dir_); }
    fs::path dir_;
};

TEST_F(BlurredFrames, ThePipelineLeavesOutAndCountsFramesOverTheLimit) {
    sim::SimulateOptions o;
    o.env = dir_ / "env.exr";
    o.trajectory = (dir_ / "turn.csv").string();
    o.out = dir_ / "session";
    o.fps = 4;
    o.width = 96;
    o.height = 54;
    o.threads = 2;
    const sim::SimulateSummary s = sim::simulate_session(o);
    const Session session = open_session(o.out);
    const double f_px = session.calibration.intrinsics.fx;
    // The predicted blur of the turning frames: 90 deg/s x their exposure.
    double longest_turning = 0;
    for (const FrameRecord& r : session.frames)
        if (r.t_ns - session.frames.front().t_ns < 1'900'000'000) longest_turning = std::max(longest_turning, r.exposure_s);
    const double predicted = 90 * kDeg * longest_turning * f_px;
    ASSERT_GT(predicted, 2.0);  // the dim room's long exposures

    const auto capture = [&](double limit) {
        CaptureOptions c;
        c.session = o.out;
        c.out = dir_ / "env-captured.exr";
        c.width = 128;
        c.height = 64;
        c.orientations = OrientationInput::Sensors;
        c.drift_correction = false;
        c.max_blur_px = limit;
        host::VirtualClock clock;
        ReplayCamera camera(open_session(c.session), clock);
        return run_capture(c, camera);
    };
    const CaptureSummary all = capture(0);
    EXPECT_EQ(all.frames_blurred, 0);
    EXPECT_EQ(all.frames_used + all.frames_without_orientation, s.frames);
    std::printf("predicted blur: max %.2f px (90 deg/s x %.1f ms x %.1f px), median %.2f px\n", all.blur_max_px,
                longest_turning * 1e3, f_px, all.blur_median_px);
    EXPECT_NEAR(all.blur_max_px, predicted, 0.1 * predicted);

    // A limit between the still frames' blur and the turning frames': the turning ones are left out.
    const CaptureSummary limited = capture(1.0);
    EXPECT_GE(limited.frames_blurred, 6);  // frames at 0.25 .. 1.75 s
    EXPECT_GT(limited.frames_used, 5);     // the still ones from 2.25 s
    EXPECT_EQ(limited.frames_used + limited.frames_blurred + limited.frames_without_orientation, s.frames);
    EXPECT_LT(limited.coverage.covered_fraction, all.coverage.covered_fraction);

    // Every frame over the limit: an error naming the option.
    try {
        capture(1e-6);
        ADD_FAILURE() << "a capture of no frames succeeded";
    } catch (const InputError& e) {
        EXPECT_NE(std::string(e.what()).find("--max-blur-px"), std::string::npos) << e.what();
    }
}

}  // namespace
}  // namespace glint::capture
