#include "appliance/ui/lens_undistortion.hpp"

#include <cmath>

#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

namespace glint::ui {

LensUndistortion::LensUndistortion(const capture::Intrinsics& k) : size_(k.width, k.height) {
    const double centre_x = 0.5 * (k.width - 1), centre_y = 0.5 * (k.height - 1);
    const bool pinhole_already = k.k1 == 0 && k.k2 == 0 && k.p1 == 0 && k.p2 == 0 && k.k3 == 0 &&
                                 std::abs(k.cx - centre_x) < 0.01 && std::abs(k.cy - centre_y) < 0.01 &&
                                 std::abs(k.fx - k.fy) < 1e-6 * k.fy;
    if (pinhole_already || k.width <= 0 || k.height <= 0) return;
    const cv::Matx33d camera(k.fx, 0, k.cx, 0, k.fy, k.cy, 0, 0, 1);
    const cv::Vec<double, 5> distortion(k.k1, k.k2, k.p1, k.p2, k.k3);
    // What the renderer projects with (ar_camera.cpp: its field of view from fy and the height).
    const cv::Matx33d renderer(k.fy, 0, centre_x, 0, k.fy, centre_y, 0, 0, 1);
    cv::initUndistortRectifyMap(camera, distortion, cv::noArray(), renderer, size_, CV_16SC2, map1_, map2_);
}

cv::Mat LensUndistortion::apply(const cv::Mat& rgb) const {
    if (!active() || rgb.size() != size_) return rgb;
    cv::Mat out;
    cv::remap(rgb, out, map1_, map2_, cv::INTER_LINEAR, cv::BORDER_CONSTANT, cv::Scalar(0, 0, 0));
    return out;
}

}  // namespace glint::ui
