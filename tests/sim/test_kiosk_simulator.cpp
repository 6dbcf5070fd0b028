// `glint simulate --kiosk` (appliance/sim/kiosk_simulator.hpp) on a small, fast session: its
// files read back through capture's readers, its phases and events in order, its truth
// consistent with itself, the board's paper as bright as the map's irradiance makes it, and the
// tracker finding the board in the AR frames at the true pose.
#include <gtest/gtest.h>

#include <filesystem>
#include <iostream>
#include <unistd.h>

#include "appliance/capture/kiosk_session.hpp"
#include "appliance/capture/session.hpp"
#include "appliance/core/equirect.hpp"
#include "appliance/core/errors.hpp"
#include "appliance/core/exr_io.hpp"
#include "appliance/core/rotation.hpp"
#include "appliance/sim/kiosk_simulator.hpp"
#include "appliance/tracking/board.hpp"
#include "tests/sim/kiosk_tracking.hpp"

namespace glint::sim {
namespace {

namespace fs = std::filesystem;

// A sky made for this test (no shipped map): brighter up, a darker ground, a warm band at the
// horizon and a small sun high up, bright enough that the scan brackets it.
HdrImage test_sky() {
    HdrImage env(128, 64);
    const glm::dvec3 sun = glm::normalize(glm::dvec3(0.4, 0.8, -0.45));
    for (int j = 0; j < 64; ++j)
        for (int i = 0; i < 128; ++i) {
            const glm::dvec3 d = texel_direction(i, j, 128, 64);
            double l = d.y > 0 ? 0.6 + 0.8 * d.y : 0.25 + 0.1 * d.y;
            l += 0.3 * std::exp(-30 * d.y * d.y);
            if (glm::dot(d, sun) > 0.999) l = 300;
            env.set(i, j, {float(l), float(0.95 * l), float(0.85 * l)});
        }
    return env;
}

// The irradiance on an upward normal by a route of its own: each texel's radiance x the cosine
// at its centre x its exact solid angle.
Rgb irradiance_by_texel_centres(const HdrImage& env) {
    const std::vector<double> omega = row_solid_angles(env.width(), env.height());
    double s[3] = {0, 0, 0};
    for (int j = 0; j < env.height(); ++j)
        for (int i = 0; i < env.width(); ++i) {
            const double c = texel_direction(i, j, env.width(), env.height()).y;
            if (c <= 0) continue;
            const Rgb l = env.at(i, j);
            s[0] += l.r * c * omega[std::size_t(j)];
            s[1] += l.g * c * omega[std::size_t(j)];
            s[2] += l.b * c * omega[std::size_t(j)];
        }
    return {float(s[0]), float(s[1]), float(s[2])};
}

class KioskSimulation : public ::testing::Test {
protected:
    static void SetUpTestSuite() {
        dir_ = new fs::path(fs::temp_directory_path() / ("glint-kiosk-sim-" + std::to_string(::getpid())));
        fs::remove_all(*dir_);
        fs::create_directories(*dir_);
        save_exr(*dir_ / "sky.exr", test_sky());
        options_ = new SimulateKioskOptions(small_options());
        summary_ = new KioskSummary(simulate_kiosk_session(*options_));
        session_ = new capture::Session(capture::open_session(options_->out));
    }
    static void TearDownTestSuite() {
        fs::remove_all(*dir_);
        delete session_;
        delete summary_;
        delete options_;
        delete dir_;
    }
    // Short phases and a fast scan: the whole session renders in a few seconds on two cores.
    static SimulateKioskOptions small_options() {
        SimulateKioskOptions o;
        o.env = *dir_ / "sky.exr";
        o.out = *dir_ / "kiosk";
        o.threads = 2;
        o.attract_s = 1;
        o.attract_fps = 2;
        o.scan_speed_deg_s = 180;
        o.scan_fps = 1;
        o.ar_s = 3;
        o.ar_fps = 10;
        return o;
    }
    static fs::path* dir_;
    static SimulateKioskOptions* options_;
    static KioskSummary* summary_;
    static capture::Session* session_;
};
fs::path* KioskSimulation::dir_ = nullptr;
SimulateKioskOptions* KioskSimulation::options_ = nullptr;
KioskSummary* KioskSimulation::summary_ = nullptr;
capture::Session* KioskSimulation::session_ = nullptr;

TEST_F(KioskSimulation, WritesASessionWithTheKioskFiles) {
    const capture::Session& s = *session_;
    EXPECT_TRUE(s.has_truth);
    EXPECT_FALSE(s.sensors.empty());
    EXPECT_EQ(int(s.frames.size()), summary_->session.frames);
    EXPECT_EQ(summary_->attract_frames + summary_->scan_frames + summary_->ar_frames, summary_->session.frames);
    EXPECT_EQ(summary_->attract_frames, 2);  // 1 s at 2 fps
    EXPECT_EQ(summary_->ar_frames, 30);      // 3 s at 10 fps
    for (const char* f : {"events.csv", "kiosk.json", "truth/board.csv", "truth/camera.csv", "truth/env.exr"})
        EXPECT_TRUE(fs::exists(s.dir / f)) << f;
    // JPEG frames that load_frame reads at the session's size.
    EXPECT_EQ(fs::path(s.frames.front().file).extension(), ".jpg");
    const capture::CameraFrame f = capture::load_frame(s, s.frames.back());
    EXPECT_EQ(f.rgb.cols, options_->width);
    EXPECT_EQ(f.rgb.rows, options_->height);
    // truth/env.exr reads back as the map the frames were rendered from.
    const HdrImage truth = load_exr(capture::truth_env_path(s)).image;
    const HdrImage input = load_exr(options_->env).image;
    ASSERT_EQ(truth.data().size(), input.data().size());
    EXPECT_EQ(truth.data(), input.data());
    // A second run with the same options gives the same frame bytes (deterministic for a seed).
    SimulateKioskOptions again = *options_;
    again.out = *dir_ / "again";
    simulate_kiosk_session(again);
    const capture::Session s2 = capture::open_session(again.out);
    ASSERT_EQ(s2.frames.size(), s.frames.size());
    const capture::CameraFrame a = capture::load_frame(s, s.frames[s.frames.size() / 2]);
    const capture::CameraFrame b = capture::load_frame(s2, s2.frames[s2.frames.size() / 2]);
    EXPECT_EQ(cv::norm(a.rgb, b.rgb, cv::NORM_INF), 0.0);
}

TEST_F(KioskSimulation, PhasesAndEventsAreInOrderAndHoldTheFrames) {
    const capture::Session& s = *session_;
    const std::optional<capture::KioskSessionInfo> info = capture::load_kiosk_info(s);
    ASSERT_TRUE(info.has_value());
    ASSERT_EQ(info->phases.size(), 3u);
    EXPECT_EQ(info->phases[0].name, "attract");
    EXPECT_EQ(info->phases[1].name, "scan");
    EXPECT_EQ(info->phases[2].name, "ar");
    const capture::KioskPhase& attract = *info->phase("attract");
    const capture::KioskPhase& scan = *info->phase("scan");
    const capture::KioskPhase& ar = *info->phase("ar");

    // The press starts the scan: it ends attract and begins scan; the release follows before the
    // scan's first frame.
    const std::vector<capture::SessionEvent> events = capture::load_session_events(s);
    // The press and release that start the scan, then a press and release per material tried
    // in the AR phase, inside it.
    ASSERT_EQ(events.size(), 2u + 2u * 2u);
    for (std::size_t k = 2; k < events.size(); ++k) {
        EXPECT_EQ(events[k].event, k % 2 == 0 ? "press" : "release");
        EXPECT_GT(events[k].t_ns, ar.start_ns);
        EXPECT_LT(events[k].t_ns, ar.end_ns);
    }
    EXPECT_EQ(events[0].source, "button");
    EXPECT_EQ(events[0].event, "press");
    EXPECT_EQ(events[1].event, "release");
    EXPECT_LT(events[0].t_ns, events[1].t_ns);
    EXPECT_EQ(events[0].t_ns, attract.end_ns);
    EXPECT_EQ(events[0].t_ns, scan.start_ns);
    EXPECT_GT(events[0].t_ns, s.frames.front().t_ns);

    // Every frame lies in exactly one phase; the AR phase's frames are truth/board.csv's.
    int in[3] = {0, 0, 0};
    std::vector<std::uint64_t> ar_indices;
    for (const capture::FrameRecord& r : s.frames) {
        int count = 0;
        for (int p = 0; p < 3; ++p)
            if (r.t_ns >= info->phases[std::size_t(p)].start_ns && r.t_ns < info->phases[std::size_t(p)].end_ns) {
                ++in[p];
                ++count;
            }
        EXPECT_EQ(count, 1) << "frame " << r.index;
        if (r.t_ns >= ar.start_ns) ar_indices.push_back(r.index);
    }
    EXPECT_EQ(in[0], summary_->attract_frames);
    EXPECT_EQ(in[1], summary_->scan_frames);
    EXPECT_EQ(in[2], summary_->ar_frames);
    const std::vector<capture::TruthBoardPose> board = capture::load_truth_board_poses(s);
    ASSERT_EQ(board.size(), ar_indices.size());
    for (std::size_t i = 0; i < board.size(); ++i) EXPECT_EQ(board[i].index, ar_indices[i]);
    EXPECT_GT(events[1].t_ns, attract.start_ns);
    EXPECT_LT(events[1].t_ns, s.frames[std::size_t(in[0])].t_ns);  // before the scan's first frame
}

TEST_F(KioskSimulation, TheBoardTruthAgreesWithTheCameraTruthAndTheTable) {
    const capture::Session& s = *session_;
    const capture::KioskSessionInfo info = *capture::load_kiosk_info(s);
    const tracking::Board board(tracking::board_spec_from_json(info.board_json, "kiosk.json"));
    EXPECT_NEAR(board.width_m(), 0.28, 1e-12);
    EXPECT_NEAR(board.height_m(), 0.38, 1e-12);
    // Level table: board +Z is world +Y; the board lies on the table top.
    EXPECT_NEAR(glm::length(info.world_from_board * glm::dvec3(0, 0, 1) - glm::dvec3(0, 1, 0)), 0, 1e-12);
    EXPECT_NEAR(info.world_board_t.y, info.table_height_m, 1e-12);

    const std::vector<capture::TruthPose> cameras = capture::load_truth_poses(s);
    const std::vector<capture::TruthBoardPose> poses = capture::load_truth_board_poses(s);
    // OpenCV's camera frame is Glint's turned by pi about X (conventions.md), so
    // camera_from_board = C * camera_from_world * world_from_board with C = diag(1, -1, -1).
    const glm::dmat3 c(1, 0, 0, 0, -1, 0, 0, 0, -1);
    double distance_min = 1e9, distance_max = 0;
    for (const capture::TruthBoardPose& p : poses) {
        const capture::TruthPose& cam = cameras.at(p.index);
        ASSERT_EQ(cam.index, p.index);
        EXPECT_EQ(cam.t_ns, p.t_ns);
        const glm::dmat3 expected = c * glm::mat3_cast(glm::conjugate(cam.world_from_camera)) * glm::mat3_cast(info.world_from_board);
        const glm::dmat3 got = glm::mat3_cast(p.camera_from_board);
        for (int i = 0; i < 3; ++i)
            for (int j = 0; j < 3; ++j) EXPECT_NEAR(got[i][j], expected[i][j], 1e-9);
        // The camera is above the table and in front of the board (positive depth).
        const glm::dvec3 camera_in_world =
            info.world_board_t + info.world_from_board * (glm::conjugate(p.camera_from_board) * -p.t_m);
        EXPECT_GT(camera_in_world.y, info.table_height_m + 0.1);
        distance_min = std::min(distance_min, glm::length(p.t_m));
        distance_max = std::max(distance_max, glm::length(p.t_m));
    }
    // The AR phase's orbit: 0.4-0.9 m from the board.
    EXPECT_GT(distance_min, 0.4);
    EXPECT_LT(distance_max, 0.9);
}

TEST_F(KioskSimulation, PaperIsAsBrightAsTheMapsIrradianceMakesIt) {
    // The simulator's irradiance (exact per-texel integral) against a texel-centre sum: they
    // differ by the cosine's curvature within a texel, well under 1 % at 64 rows.
    const HdrImage env = load_exr(options_->env).image;
    const Rgb e = irradiance_by_texel_centres(env);
    EXPECT_NEAR(summary_->irradiance_up[0], e.r, 0.005 * e.r);
    EXPECT_NEAR(summary_->irradiance_up[2], e.b, 0.005 * e.b);

    // The white margin of the board in the first AR frame, read back through the camera model
    // (inverse response, vignetting, exposure, gain, sensitivity), is 0.85 E / pi.
    const capture::Session& s = *session_;
    const capture::KioskSessionInfo info = *capture::load_kiosk_info(s);
    const tracking::Board board(tracking::board_spec_from_json(info.board_json, "kiosk.json"));
    const capture::TruthBoardPose p = capture::load_truth_board_poses(s).front();
    const capture::FrameRecord& r = s.frames.at(p.index);
    const capture::CameraFrame f = capture::load_frame(s, r);
    const capture::CameraCalibration& cal = s.calibration;
    // 10 mm inside the top edge, in the 20 mm margin, at x = 0 (between no markers).
    const glm::dvec3 x = p.camera_from_board * glm::dvec3(0, board.height_m() / 2 - 0.010, 0) + p.t_m;
    const auto px = capture::project(cal.intrinsics, glm::dvec3(x.x, -x.y, -x.z));
    ASSERT_TRUE(px.has_value());
    double sum = 0;
    int n = 0;
    for (int dv = -1; dv <= 1; ++dv)
        for (int du = -1; du <= 1; ++du) {
            const int u = int(std::lround(px->u)) + du, v = int(std::lround(px->v)) + dv;
            const int code = f.rgb.at<cv::Vec3b>(v, u)[1];  // green
            ASSERT_LT(code, 250) << "the paper clips";
            sum += cal.response.inverse[std::size_t(code)] / cal.vignetting.at(cal.intrinsics, u, v) /
                   (r.exposure_s * r.analogue_gain * r.digital_gain * cal.sensitivity);
            ++n;
        }
    const double expected = 0.85 * e.g / kPi;
    // Shot and read noise over 9 pixels, the JPEG's rounding and 8-bit bins, and the margin only
    // 3-4 pixels wide there (the JPEG's ringing and the blur of its edges reach in): measured
    // -3.5 % to +0.3 % with seeds 1 to 4.
    EXPECT_NEAR(sum / n, expected, 0.06 * expected);
    std::cout << "paper: " << sum / n << " for 0.85 E / pi = " << expected << "\n";
}

TEST_F(KioskSimulation, TheTrackerFindsTheBoardAtTheTruePose) {
    const sim_test::KioskTracking m =
        sim_test::measure_kiosk_tracking(*session_, summary_->dropout_start_ns, summary_->dropout_end_ns);
    EXPECT_EQ(m.ar_frames, 30);
    std::cout << "AR frames " << m.ar_frames << ", in view " << m.in_view << ", detected " << m.detected << ", tracked "
              << m.tracked << ", rotation error median " << sim_test::percentile(m.rotation_error_deg, 0.5) << " max "
              << sim_test::percentile(m.rotation_error_deg, 1.0) << " deg, translation median "
              << sim_test::percentile(m.translation_error, 0.5) << "; turning slowly: in view " << m.slow_in_view
              << ", detected " << m.slow_detected << ", rotation error median "
              << sim_test::percentile(m.slow_rotation_error_deg, 0.5) << " p95 "
              << sim_test::percentile(m.slow_rotation_error_deg, 0.95) << " max "
              << sim_test::percentile(m.slow_rotation_error_deg, 1.0) << "\n";
    // The arm: the board wholly hidden for dropout_s (0.3 s: 3 frames at 10 fps, 4 with the
    // exposures reaching into it), and nothing is found there.
    EXPECT_NEAR(summary_->dropout_end_s - summary_->dropout_start_s, options_->dropout_s, 0.01);
    EXPECT_GE(m.ar_frames - m.in_view, 3);
    EXPECT_LE(m.ar_frames - m.in_view, 5);
    EXPECT_EQ(m.false_detections, 0);
    // Measured on this session with seeds 1 to 4 (320x180, JPEG 90): all 26 frames with 3 whole
    // markers in view and not covered found by the detector and the tracker; rotation error
    // median 0.15-0.18, max 0.74-0.78 degree; translation median 0.26-0.28 % of the distance.
    // At 320x180 a pixel spans 0.22 degree, and an edge-line corner is good to about a tenth of
    // it: the bounds leave room for a seed's bad frames (3 missed, twice the median error), and
    // a wrong truth (a frame convention, a pose a frame off: the camera turns about 0.6 degree
    // a frame) fails them.
    EXPECT_GE(m.detected, m.in_view - 3);
    EXPECT_GE(m.tracked, m.in_view - 3);
    EXPECT_LT(sim_test::percentile(m.rotation_error_deg, 0.5), 0.4);
    EXPECT_LT(sim_test::percentile(m.rotation_error_deg, 1.0), 3.0);
    EXPECT_LT(sim_test::percentile(m.translation_error, 0.5), 0.01);
}

TEST(KioskSimulationOptions, BadOptionsAreInputErrors) {
    SimulateKioskOptions o;
    o.env = "/nonexistent/map.exr";
    o.out = fs::temp_directory_path() / ("glint-kiosk-bad-" + std::to_string(::getpid()));
    EXPECT_THROW(simulate_kiosk_session(o), InputError);  // no map
    o.ar_s = 0.2;
    EXPECT_THROW(simulate_kiosk_session(o), InputError);
    o.ar_s = 12;
    o.dropout_s = 5;
    EXPECT_THROW(simulate_kiosk_session(o), InputError);
    o.dropout_s = 0.3;
    o.frame_format = "gif";
    EXPECT_THROW(simulate_kiosk_session(o), InputError);
    EXPECT_FALSE(fs::exists(o.out));
}

}  // namespace
}  // namespace glint::sim

namespace glint::sim {
namespace {

// The shipped session (data/sessions/kiosk, made by the command in its README): within the
// 15 MB budget, read by every reader, and its board tracked in the AR frames.
TEST(ShippedKioskSession, FitsTheBudgetReadsBackAndIsTracked) {
    const fs::path dir = fs::path(GLINT_SOURCE_DIR) / "data" / "sessions" / "kiosk";
    std::uintmax_t bytes = 0;
    for (const fs::directory_entry& e : fs::recursive_directory_iterator(dir))
        if (e.is_regular_file()) bytes += e.file_size();
    EXPECT_LE(bytes, 15'000'000u);
    const capture::Session s = capture::open_session(dir);
    const std::optional<capture::KioskSessionInfo> info = capture::load_kiosk_info(s);
    ASSERT_TRUE(info.has_value());
    ASSERT_NE(info->phase("ar"), nullptr);
    const std::vector<capture::SessionEvent> events = capture::load_session_events(s);
    ASSERT_FALSE(events.empty());
    EXPECT_EQ(events.front().t_ns, info->phase("scan")->start_ns);
    const sim_test::KioskTracking m = sim_test::measure_kiosk_tracking(s);
    EXPECT_EQ(m.ar_frames, 144);
    // Measured (README): all 140 frames with 3 whole markers in view and not covered found; the
    // 4 frames the arm covers count as in view here (no dropout span given) and are missed.
    EXPECT_GE(m.detected, m.in_view - 6);
    EXPECT_EQ(m.false_detections, 0);
    EXPECT_LT(sim_test::percentile(m.rotation_error_deg, 0.5), 0.3);
}

}  // namespace
}  // namespace glint::sim
