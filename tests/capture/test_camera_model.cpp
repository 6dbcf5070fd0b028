#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include <opencv2/calib3d.hpp>
#include <vector>

#include "appliance/capture/camera_model.hpp"

namespace glint::capture {
namespace {

Intrinsics lens() {
    Intrinsics k = Intrinsics::from_fov(640, 360, 60.0 * kPi / 180.0);
    k.cx += 3.5;
    k.cy -= 2.0;
    k.k1 = -0.12;
    k.k2 = 0.03;
    k.p1 = 0.001;
    k.p2 = -0.0007;
    k.k3 = -0.002;
    return k;
}

TEST(CameraModel, ProjectionInvertsThePixelRayOverTheWholeImage) {
    const Intrinsics k = lens();
    for (double v : {0.0, 17.0, 179.5, 359.0})
        for (double u : {0.0, 100.25, 320.0, 639.0}) {
            const glm::dvec3 r = pixel_ray(k, u, v);
            EXPECT_NEAR(std::sqrt(glm::dot(r, r)), 1.0, 1e-12);
            EXPECT_LT(r.z, 0.0);
            const auto p = project(k, r);
            ASSERT_TRUE(p) << u << "," << v;
            EXPECT_NEAR(p->u, u, 1e-6);
            EXPECT_NEAR(p->v, v, 1e-6);
        }
}

// Wide lenses, corners included: the fixed point alone (cv::undistortPoints' iteration) stopped
// 109-342 pixels short at the corners of the first after 20 steps; Newton's steps finish it.
TEST(CameraModel, ProjectionInvertsThePixelRayOfWideLensesToTheCorners) {
    struct Lens {
        int w, h;
        double fov_deg, k1, k2, k3, p1, p2;
    };
    const Lens lenses[] = {{1920, 1080, 90, -0.4, 0.2, 0, 0, 0},              // a real wide lens's barrel
                           {320, 180, 130, -0.1, 0.02, 0, 0, 0},              // the simulator's lens, widened
                           {1280, 720, 110, -0.3, 0.08, -0.006, 0.002, -0.001}};  // with tangential terms
    for (const Lens& l : lenses) {
        Intrinsics k = Intrinsics::from_fov(l.w, l.h, l.fov_deg * kPi / 180.0);
        k.k1 = l.k1;
        k.k2 = l.k2;
        k.k3 = l.k3;
        k.p1 = l.p1;
        k.p2 = l.p2;
        double worst = 0;
        for (int a = 0; a <= 16; ++a)
            for (int b = 0; b <= 16; ++b) {
                const double u = (l.w - 1) * a / 16.0, v = (l.h - 1) * b / 16.0;
                const glm::dvec3 r = pixel_ray(k, u, v);
                ASSERT_LT(r.z, 0.0) << l.fov_deg << " degrees, pixel " << u << "," << v;
                // A margin of a pixel: the image's own corner may come back 1e-10 px outside it.
                const auto p = project(k, r, 1.0);
                ASSERT_TRUE(p) << l.fov_deg << " degrees, pixel " << u << "," << v;
                worst = std::max(worst, std::hypot(p->u - u, p->v - v));
            }
        EXPECT_LT(worst, 1e-6) << l.w << "x" << l.h << ", " << l.fov_deg << " degrees";
    }
}

// The projection against OpenCV's own (cv::projectPoints with the same intrinsics and
// distortion), not against our inverse: a slip shared by project() and pixel_ray() (a sign of a
// tangential term, the order of k1/k2/k3) would pass the round trip above. OpenCV's camera
// frame is ours turned by diag(1, -1, -1) (docs/conventions.md, "Camera frame and pixels").
TEST(CameraModel, ProjectionMatchesOpenCvsProjectPoints) {
    const Intrinsics k = lens();
    std::vector<cv::Point3d> opencv_points;
    std::vector<glm::dvec3> rays;
    for (double y : {-0.45, -0.2, 0.0, 0.15, 0.4})
        for (double x : {-0.7, -0.3, 0.0, 0.25, 0.6}) {
            const glm::dvec3 d = glm::normalize(glm::dvec3(x, y, -1.0));
            rays.push_back(d);
            opencv_points.emplace_back(d.x, -d.y, -d.z);
        }
    const cv::Matx33d camera(k.fx, 0, k.cx, 0, k.fy, k.cy, 0, 0, 1);
    const std::vector<double> distortion{k.k1, k.k2, k.p1, k.p2, k.k3};
    std::vector<cv::Point2d> expected;
    cv::projectPoints(opencv_points, cv::Vec3d(0, 0, 0), cv::Vec3d(0, 0, 0), camera, distortion, expected);
    for (std::size_t i = 0; i < rays.size(); ++i) {
        const auto p = project(k, rays[i], 1e6);  // no image bound: the corners reach outside
        ASSERT_TRUE(p) << i;
        EXPECT_NEAR(p->u, expected[i].x, 1e-9) << "ray " << i;
        EXPECT_NEAR(p->v, expected[i].y, 1e-9) << "ray " << i;
    }
}

TEST(CameraModel, FollowsTheWorldFrameHabit) {
    // -Z is the optical axis; +Y is up in the image (smaller v), +X right (larger u).
    const Intrinsics k = Intrinsics::from_fov(101, 51, 1.0);
    const auto centre = project(k, {0, 0, -1});
    ASSERT_TRUE(centre);
    EXPECT_NEAR(centre->u, 50.0, 1e-9);
    EXPECT_NEAR(centre->v, 25.0, 1e-9);
    EXPECT_LT(project(k, {0, 0.1, -1})->v, 25.0);
    EXPECT_GT(project(k, {0.1, 0, -1})->u, 50.0);
    EXPECT_FALSE(project(k, {0, 0, 1}));       // behind
    EXPECT_FALSE(project(k, {5, 0, -1}));      // far outside the image
    EXPECT_FALSE(project(k, {0, 0, 0}));
}

TEST(CameraModel, FrustumBoundHoldsForEveryPixel) {
    const Intrinsics k = lens();
    const double c = min_cos_to_axis(k);
    for (int v = 0; v < k.height; v += 7)
        for (int u = 0; u < k.width; u += 7) EXPECT_GE(-pixel_ray(k, u, v).z, c - 1e-12);
}

TEST(CameraModel, ResponseTableInvertsTheForwardCurve) {
    const Response r = Response::parametric(2.2, 0.25);
    for (int z = 1; z < 256; ++z) EXPECT_GT(r.inverse[std::size_t(z)], r.inverse[std::size_t(z - 1)]) << z;
    for (int z = 1; z < 255; ++z) EXPECT_NEAR(r.forward(r.inverse[std::size_t(z)]), z, 1e-9) << z;
    EXPECT_DOUBLE_EQ(r.forward(1.0), 255.0);
    EXPECT_DOUBLE_EQ(r.forward(4.0), 255.0);
    EXPECT_EQ(r.forward(0.0), 0.0);
}

TEST(CameraModel, CodeWeightsVanishAtTheEnds) {
    EXPECT_EQ(code_weight(0), 0.0);
    EXPECT_EQ(code_weight(255), 0.0);
    EXPECT_GT(code_weight(128), 0.9);
    EXPECT_LT(code_weight(3), 0.02);
    EXPECT_NEAR(code_weight(100), code_weight(155), 1e-12);  // symmetric about 127.5
}

TEST(CameraModel, VignettingIsOneAtThePrincipalPoint) {
    const Intrinsics k = lens();
    const Vignetting v{-0.3, 0.05, 0};
    EXPECT_DOUBLE_EQ(v.at(k, k.cx, k.cy), 1.0);
    EXPECT_LT(v.at(k, 0, 0), 0.8);
    EXPECT_GT(v.at(k, 0, 0), 0.7);
}

}  // namespace
}  // namespace glint::capture
