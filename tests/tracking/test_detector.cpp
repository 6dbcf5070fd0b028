// Detection and pose on rendered views at known poses (board_view.hpp): accuracy on clean and
// hard frames, lens distortion, the frame convention, rejection.
#include <gtest/gtest.h>

#include "appliance/tracking/board_view.hpp"
#include "appliance/tracking/detector.hpp"

namespace glint::tracking {
namespace {

Camera test_camera() { return Camera::from_fov(1280, 720, 70); }

Camera distorted_camera() {
    Camera c = test_camera();
    c.k1 = -0.12, c.k2 = 0.04, c.p1 = 0.001, c.p2 = -0.0005;
    return c;
}

struct View {
    double distance, tilt, azimuth, roll;
};
constexpr View kViews[] = {{0.5, 10, 0, 0}, {0.8, 35, 60, 30}, {1.2, 50, 200, -100}, {1.8, 20, 120, 170}};

TEST(TrackingDetector, CleanViewsGiveTheKnownPose) {
    const Board board;
    const Camera cam = test_camera();
    const BoardRenderer renderer(board, cam);
    const Detector detector(board, cam);
    for (const View& v : kViews) {
        const Pose truth = view_pose(v.distance, v.tilt, v.azimuth, v.roll);
        const Detection d = detector.detect(renderer.render(truth, {}, 1), truth);
        ASSERT_TRUE(d.detected) << v.distance << " m: " << d.rejection;
        EXPECT_LT(rotation_error_deg(d.pose, truth), 0.1) << v.distance << " m";
        EXPECT_LT(translation_error_fraction(d.pose, truth), 0.002) << v.distance << " m";
        EXPECT_LT(d.rms_px, 0.3);
        EXPECT_GE(d.markers, 20);
    }
}

TEST(TrackingDetector, FrameConventionTopLeftMarkerIsTopLeftInAnUprightView) {
    const Board board;
    const Camera cam = test_camera();
    const BoardRenderer renderer(board, cam);
    const Pose truth = view_pose(0.8, 0, 0, 0);
    // Upright and facing: board +Y is image up (camera -Y), board +Z points at the camera.
    const glm::dvec3 y = truth.rotation * glm::dvec3(0, 1, 0), z = truth.rotation * glm::dvec3(0, 0, 1);
    EXPECT_NEAR(y.y, -1, 1e-9);
    EXPECT_NEAR(z.z, -1, 1e-9);
    const cv::Mat image = renderer.render(truth, {}, 1);
    std::vector<std::vector<cv::Point2f>> corners;
    std::vector<int> ids;
    cv::aruco::detectMarkers(image, board.dictionary(), corners, ids);
    ASSERT_FALSE(ids.empty());
    for (std::size_t i = 0; i < ids.size(); ++i) {
        if (ids[i] != 0) continue;
        EXPECT_LT(corners[i][0].x, cam.cx);
        EXPECT_LT(corners[i][0].y, cam.cy);
        return;
    }
    FAIL() << "marker 0 not seen";
}

TEST(TrackingDetector, LensDistortionIsModelled) {
    const Board board;
    const Camera cam = distorted_camera();
    const BoardRenderer renderer(board, cam);
    const Pose truth = view_pose(0.45, 30, 45, 20, {0.1, -0.05});
    const cv::Mat image = renderer.render(truth, {}, 2);
    const Detection with = Detector(board, cam).detect(image);
    ASSERT_TRUE(with.detected) << with.rejection;
    EXPECT_LT(rotation_error_deg(with.pose, truth), 0.1);
    // The same frame with the distortion ignored: the pose is worse or rejected.
    DetectorOptions lax;
    lax.max_rms_px = 100;
    const Detection without = Detector(board, test_camera(), lax).detect(image);
    ASSERT_TRUE(without.detected) << without.rejection;
    EXPECT_GT(without.rms_px, 5 * with.rms_px);
    EXPECT_GT(rotation_error_deg(without.pose, truth), 3 * rotation_error_deg(with.pose, truth));
}

TEST(TrackingDetector, HardFramesStillGiveAGoodPose) {
    const Board board;
    const Camera cam = distorted_camera();
    const BoardRenderer renderer(board, cam);
    const Detector detector(board, cam);
    ViewConditions hard;
    hard.blur_px = 1.2, hard.noise = 4, hard.light = 0.45, hard.glare = 0.3, hard.hand_fraction = 0.08;
    for (const View& v : kViews) {
        const Pose truth = view_pose(v.distance, v.tilt, v.azimuth, v.roll);
        const Detection d = detector.detect(renderer.render(truth, hard, 7), truth);
        ASSERT_TRUE(d.detected) << v.distance << " m: " << d.rejection;
        EXPECT_LT(rotation_error_deg(d.pose, truth), 1.0) << v.distance << " m";
    }
}

TEST(TrackingDetector, RejectsWhatDoesNotFit) {
    const Board board;
    const Camera cam = test_camera();
    const BoardRenderer renderer(board, cam);
    // Nothing there.
    const Detection empty = Detector(board, cam).detect(cv::Mat(720, 1280, CV_8UC1, cv::Scalar(90)));
    EXPECT_FALSE(empty.detected);
    EXPECT_NE(empty.rejection.find("too few markers"), std::string::npos);
    // A wrong calibration (strong barrel distortion the lens does not have): corners do not fit.
    Camera wrong = cam;
    wrong.k1 = 0.35;
    const Pose truth = view_pose(0.4, 20, 0, 10);
    const Detection bad = Detector(board, wrong).detect(renderer.render(truth, {}, 3));
    EXPECT_FALSE(bad.detected);
    EXPECT_NE(bad.rejection.find("reprojection RMS"), std::string::npos) << bad.rejection;
    // A frame of the wrong size is an input error.
    EXPECT_THROW(Detector(board, cam).detect(cv::Mat(10, 10, CV_8UC1)), std::exception);
}

}  // namespace
}  // namespace glint::tracking

namespace glint::tracking {
namespace {

// The board left the view: the last pose predicts it wholly outside the frame. The search must
// look at the whole frame instead of an empty region (the kiosk's replay once crashed here in
// OpenCV's resize), and find the board where it really is.
TEST(TrackingDetector, APriorPoseOutsideTheFrameFallsBackToTheWholeFrame) {
    const Board board;
    const Camera cam = Camera::from_fov(320, 180, 70);
    const BoardRenderer renderer(board, cam);
    const Detector detector(board, cam);
    const Pose truth = view_pose(0.6, 20, 0, 0);
    Pose gone = truth;
    gone.translation += glm::dvec3(3.0, 0, 0);  // 3 m to the right: nowhere in the image
    const cv::Mat image = renderer.render(truth, {}, 1);
    Detection d;
    ASSERT_NO_THROW(d = detector.detect(image, gone));
    EXPECT_TRUE(d.detected) << d.rejection;
    const Detection blank = detector.detect(cv::Mat(180, 320, CV_8UC1, cv::Scalar(128)), gone);
    EXPECT_FALSE(blank.detected);
}

}  // namespace
}  // namespace glint::tracking
