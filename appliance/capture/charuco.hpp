// ChArUco boards for the intrinsics calibration (OpenCV aruco, contrib): the board's layout, a
// renderer of board views through the camera model (the simulator's calibration sessions), and
// the calibration itself (docs/capture.md "Calibration").
#pragma once

#include <opencv2/aruco/charuco.hpp>

#include "appliance/capture/camera_model.hpp"
#include "appliance/capture/session.hpp"

namespace glint::capture {

struct CharucoSpec {
    int squares_x = 7, squares_y = 5;
    double square_m = 0.04, marker_m = 0.03;
    int dictionary = cv::aruco::DICT_5X5_100;
};

cv::Ptr<cv::aruco::CharucoBoard> make_charuco_board(const CharucoSpec& spec);

// The board seen by a camera: board_to_camera rotates board axes (x along the squares' rows, y
// down the columns, z into the board) into OpenCV's camera axes, board_origin_m is the board's
// top-left corner in the camera (metres). Pixels off the board are mid-grey; 2x2 supersampling.
cv::Mat render_charuco_view(const CharucoSpec& spec, const Intrinsics& camera, const cv::Matx33d& board_to_camera,
                            const cv::Vec3d& board_origin_m);

struct IntrinsicsResult {
    Intrinsics intrinsics;
    double rms_px = 0;   // RMS reprojection error of the ChArUco corners
    int views = 0;       // frames with enough corners
    int corners = 0;     // corners used over all views
};

// cv::aruco detectMarkers + interpolateCornersCharuco per frame (views with at least 6 corners),
// then calibrateCameraCharuco (k1 k2 p1 p2 k3). Throws InputError with fewer than 4 usable views.
IntrinsicsResult calibrate_intrinsics(const Session& session, const CharucoSpec& spec);

}  // namespace glint::capture
