// The AR background remapped to the renderer's pinhole (appliance/ui/lens_undistortion.hpp).
#include <gtest/gtest.h>

#include <opencv2/imgproc.hpp>

#include "appliance/ui/lens_undistortion.hpp"

namespace glint::ui {
namespace {

// The brightness-weighted centre of a picture's bright pixels.
cv::Point2d centroid(const cv::Mat& rgb) {
    cv::Mat gray;
    cv::cvtColor(rgb, gray, cv::COLOR_RGB2GRAY);
    const cv::Moments m = cv::moments(gray);
    return {m.m10 / m.m00, m.m01 / m.m00};
}

TEST(LensUndistortion, APointSeenThroughTheLensLandsWherePinholeProjectionPutsIt) {
    capture::Intrinsics k;
    k.width = 640;
    k.height = 360;
    k.fx = k.fy = 460;
    k.fx = 452;  // not square
    k.cx = 327.0;  // off centre
    k.cy = 176.25;
    k.k1 = -0.25;
    k.k2 = 0.08;
    k.p1 = 0.001;
    const LensUndistortion lens(k);
    ASSERT_TRUE(lens.active());
    // Points at several places, near the corners where the lens moves them most (tens of pixels).
    for (const auto& [x, y] : {std::pair{0.55, 0.30}, std::pair{-0.6, -0.32}, std::pair{0.1, 0.05}, std::pair{-0.3, 0.33}}) {
        double xd = 0, yd = 0;
        capture::distort(k, x, y, xd, yd);
        // Where the renderer's symmetric pinhole (fy, the image's centre) puts the point.
        const cv::Point2d seen(k.fx * xd + k.cx, k.fy * yd + k.cy), pinhole(k.fy * x + 319.5, k.fy * y + 179.5);
        cv::Mat picture(k.height, k.width, CV_8UC3, cv::Scalar(0, 0, 0));
        cv::circle(picture, cv::Point(int(std::lround(seen.x * 16)), int(std::lround(seen.y * 16))), 3 * 16,
                   cv::Scalar(255, 255, 255), cv::FILLED, cv::LINE_AA, 4);
        const cv::Point2d moved = centroid(lens.apply(picture));
        EXPECT_NEAR(moved.x, pinhole.x, 0.35) << "point " << x << ", " << y << " seen at " << seen;
        EXPECT_NEAR(moved.y, pinhole.y, 0.35) << "point " << x << ", " << y << " seen at " << seen;
        if (std::abs(x) > 0.5) {
            EXPECT_GT(cv::norm(seen - pinhole), 10.0);  // the test means something
        }
    }
}

TEST(LensUndistortion, ALensWithoutDistortionLeavesThePictureAlone) {
    const capture::Intrinsics k = capture::Intrinsics::from_fov(64, 36, 1.0);  // centred, square, no distortion
    const LensUndistortion lens(k);
    EXPECT_FALSE(lens.active());
    const cv::Mat picture(36, 64, CV_8UC3, cv::Scalar(1, 2, 3));
    EXPECT_EQ(lens.apply(picture).data, picture.data);
}

}  // namespace
}  // namespace glint::ui
