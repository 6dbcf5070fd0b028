// The camera picture behind the AR object, undistorted with the calibration (docs/kiosk.md, "The AR
// view's geometry"). The renderer's camera is a symmetric pinhole: vertical field of view
// 2 atan(h / 2 fy), square pixels, the principal point at the image's centre ((w - 1) / 2,
// (h - 1) / 2 with pixel centres at integers). The tracker's pose is estimated on the picture as
// taken, with the full lens model. So the picture is remapped to exactly the renderer's pinhole
// (same size) and the object sits where the board is across the whole image, not only near the
// centre: the lens's distortion, an off-centre principal point and fx != fy are all taken out. Remapping the picture (one cv::remap from precomputed
// maps, about a millisecond at 1280x720) was chosen over distorting the virtual view: the latter
// needs the 3D view rendered with a margin and warped per pixel in a second pass, and the
// object's edges resampled, for the same result.
#pragma once

#include <opencv2/core.hpp>

#include "appliance/capture/camera_model.hpp"

namespace glint::ui {

class LensUndistortion {
public:
    explicit LensUndistortion(const capture::Intrinsics& intrinsics);
    // False for a centred, square-pixel lens without distortion (apply() then returns its input).
    bool active() const { return !map1_.empty(); }
    // The picture as the pinhole camera with the same intrinsics would have taken it; outside the
    // lens's field black. `rgb` must have the calibration's size (else it is returned as it is).
    cv::Mat apply(const cv::Mat& rgb) const;

private:
    cv::Size size_;
    cv::Mat map1_, map2_;
};

}  // namespace glint::ui
