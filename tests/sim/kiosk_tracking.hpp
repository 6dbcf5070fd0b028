// The tracker on a kiosk session's AR frames against truth/board.csv: what the test asserts and
// what tools/measure_kiosk_tracking prints (docs/capture.md "Kiosk sessions").
#pragma once

#include <algorithm>
#include <cmath>
#include <vector>

#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

#include "appliance/capture/kiosk_session.hpp"
#include "appliance/capture/session.hpp"
#include "appliance/core/rotation.hpp"
#include "appliance/tracking/board.hpp"
#include "appliance/tracking/detector.hpp"
#include "appliance/tracking/tracker.hpp"

namespace glint::sim_test {

struct KioskTracking {
    int ar_frames = 0;
    int in_view = 0;             // frames where truth puts at least 3 whole markers in the image, not hidden
    int detected = 0;            // of those, found by the detector alone (each frame on its own)
    int tracked = 0;             // of those, found by the tracker (the frames in sequence)
    int false_detections = 0;    // detections where truth puts fewer than 3 whole markers in view or hides the board
    std::vector<double> rotation_error_deg;  // per detector detection in view, against the truth
    std::vector<double> translation_error;   // the same, as a fraction of the distance
    // The same for the frames where the camera turns slower than kSlowDegS (the orbit, not the
    // look up and back): their rotation errors, and how many of those in view were found.
    int slow_in_view = 0, slow_detected = 0;
    std::vector<double> slow_rotation_error_deg;
};

// The orbit of the AR phase turns the camera at under 20 deg/s; the look up that takes the board
// out of view at up to ~200 deg/s, which blurs the frames around it.
inline constexpr double kSlowDegS = 30;

inline double percentile(std::vector<double> v, double p) {
    if (v.empty()) return NAN;
    std::sort(v.begin(), v.end());
    const double x = p * double(v.size() - 1);
    const std::size_t i = std::size_t(std::floor(x));
    return i + 1 < v.size() ? v[i] + (x - double(i)) * (v[i + 1] - v[i]) : v.back();
}

// Markers whose four corners all project inside the image at the true pose.
inline int markers_in_view(const tracking::Board& board, const tracking::Camera& camera, const tracking::Pose& truth) {
    cv::Vec3d rvec, tvec;
    tracking::pose_to_rvec_tvec(truth, rvec, tvec);
    int whole = 0;
    for (int i = 0; i < board.marker_count(); ++i) {
        std::vector<cv::Point3f> corners(board.corners(i).begin(), board.corners(i).end());
        bool inside = true;
        for (const cv::Point3f& c : corners) {
            const glm::dvec3 x = truth.apply({c.x, c.y, c.z});
            if (!(x.z > 0.05)) inside = false;
        }
        if (!inside) continue;
        std::vector<cv::Point2f> pixels;
        cv::projectPoints(corners, rvec, tvec, camera.matrix(), camera.distortion(), pixels);
        for (const cv::Point2f& p : pixels)
            if (!(p.x >= 0 && p.y >= 0 && double(p.x) <= camera.width - 1.0 && double(p.y) <= camera.height - 1.0)) inside = false;
        whole += inside;
    }
    return whole;
}

// `hidden_start_ns`..`hidden_end_ns`: the appliance times when the board is wholly hidden (the
// dropout: sim::KioskSummary); frames whose exposure overlaps it count as not in view.
inline KioskTracking measure_kiosk_tracking(const capture::Session& session, std::int64_t hidden_start_ns = 0,
                                            std::int64_t hidden_end_ns = 0) {
    const std::optional<capture::KioskSessionInfo> info = capture::load_kiosk_info(session);
    const std::vector<capture::TruthBoardPose> truth = capture::load_truth_board_poses(session);
    KioskTracking out;
    if (!info || truth.empty()) return out;
    const tracking::Board board(tracking::board_spec_from_json(info->board_json, "kiosk.json board"));
    const capture::Intrinsics& k = session.calibration.intrinsics;
    const tracking::Camera camera{k.width, k.height, k.fx, k.fy, k.cx, k.cy, k.k1, k.k2, k.p1, k.p2, k.k3};
    const tracking::Detector detector(board, camera);
    // Without the sensor: the bridge is not what is measured here, the detections are.
    tracking::Tracker tracker(board, camera, glm::dquat(1, 0, 0, 0));
    std::size_t next = 0;
    for (const capture::FrameRecord& r : session.frames) {
        while (next < truth.size() && truth[next].index < r.index) ++next;
        if (next >= truth.size() || truth[next].index != r.index) continue;
        const tracking::Pose pose{truth[next].camera_from_board, truth[next].t_m};
        // The camera's turn rate at this frame: the fastest to a neighbouring truth frame.
        double rate_deg_s = 0;
        for (const std::size_t other : {next - 1, next + 1}) {
            if (other >= truth.size()) continue;  // next - 1 wraps for the first
            const double dt = std::abs(double(truth[other].t_ns - truth[next].t_ns)) * 1e-9;
            rate_deg_s = std::max(rate_deg_s, angle_between(truth[other].camera_from_board, truth[next].camera_from_board) *
                                                  180 / 3.14159265358979 / dt);
        }
        const bool slow = rate_deg_s < kSlowDegS;
        ++out.ar_frames;
        cv::Mat gray;
        cv::cvtColor(capture::load_frame(session, r).rgb, gray, cv::COLOR_RGB2GRAY);
        const tracking::Detection d = detector.detect(gray);
        const tracking::TrackResult t = tracker.track(double(r.t_ns) * 1e-9, gray);
        // A frame's rows are exposed over about exposure + readout around its time.
        const std::int64_t reach_ns = std::llround((r.exposure_s + session.calibration.readout_s) * 0.5e9);
        const bool any_dropout = hidden_end_ns > hidden_start_ns;
        const bool partly_hidden = any_dropout && r.t_ns + reach_ns >= hidden_start_ns && r.t_ns - reach_ns <= hidden_end_ns;
        const bool wholly_hidden = any_dropout && r.t_ns - reach_ns >= hidden_start_ns && r.t_ns + reach_ns <= hidden_end_ns;
        const int whole_markers = markers_in_view(board, camera, pose);
        if (wholly_hidden || whole_markers < 3) {
            out.false_detections += d.detected;
            continue;
        }
        if (partly_hidden) continue;  // some rows may see the board: neither counted nor false
        ++out.in_view;
        out.tracked += t.detected;
        out.slow_in_view += slow;
        if (!d.detected) continue;
        ++out.detected;
        out.slow_detected += slow;
        if (slow) out.slow_rotation_error_deg.push_back(tracking::rotation_error_deg(d.pose, pose));
        out.rotation_error_deg.push_back(tracking::rotation_error_deg(d.pose, pose));
        out.translation_error.push_back(tracking::translation_error_fraction(d.pose, pose));
    }
    return out;
}

}  // namespace glint::sim_test
