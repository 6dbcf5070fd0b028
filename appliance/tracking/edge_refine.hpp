// Sub-pixel marker corners from the marker's edges (docs/tracking.md "Corner refinement"): along
// each of the four edges of a detected marker, the black-to-white step is located on many short
// profiles across the edge (the maximum of the intensity derivative, interpolated by a parabola),
// the points are undistorted with the lens model, a straight line is fitted to each edge, and the
// corners are the intersections of neighbouring lines. A corner then rests on some 60 edge
// samples instead of a few pixels around one point, and the distortion is handled exactly (edges
// are straight only after undistortion).
#pragma once

#include <array>
#include <opencv2/core.hpp>

#include "appliance/tracking/camera.hpp"

namespace glint::tracking {

// `initial`: the marker's corners in ArUco's order in distorted pixels, within ~2 px. On success
// `undistorted` holds the refined corners as undistorted pixels (the camera's K without
// distortion) and the function returns true; false when an edge has too few clear step points
// (covered, out of the image, too blurred).
bool refine_marker_corners(const cv::Mat& gray, const Camera& camera, const std::array<cv::Point2f, 4>& initial,
                           std::array<cv::Point2d, 4>& undistorted);

// Undistorted pixels of distorted ones (the camera's K, no distortion).
std::vector<cv::Point2d> undistort_pixels(const Camera& camera, const std::vector<cv::Point2d>& pixels);

}  // namespace glint::tracking
