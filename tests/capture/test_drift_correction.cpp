// Unit tests of the two pieces of the drift correction with known answers: the
// rotation fit on synthetic residuals of a known rotation, and DriftCorrector::estimate on a
// sphere rendered from a known orientation with a frame whose orientation is off by a known
// rotation. The session test (test_session.cpp) only shows that the correction helps on a
// whole scan; these pin down its sign, size and trust rules on single estimates.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <random>

#include "appliance/capture/drift_correction.hpp"
#include "appliance/capture/rotation_fit.hpp"
#include "appliance/core/equirect.hpp"
#include "appliance/core/exr_io.hpp"
#include "appliance/core/rotation.hpp"
#include "appliance/sim/camera_simulator.hpp"
#include "appliance/sim/session_simulator.hpp"

namespace glint::capture {
namespace {

using sim::camera_look;
using sim::CameraSimulator;
using sim::SensorModel;

constexpr double kDeg = kPi / 180.0;

// --- fit_rotation -------------------------------------------------------------------------

// A smooth, asymmetric scalar field on the sphere: no rotation other than the identity maps it
// onto itself, so residuals against it have one minimum.
double field(const glm::dvec3& d) {
    return std::sin(3 * d.x) + std::cos(2 * d.y + 1) + std::sin(4 * d.z + 0.5) + 0.5 * d.x * d.y;
}

std::vector<glm::dvec3> directions(int n, unsigned seed) {
    std::mt19937 rng(seed);
    std::normal_distribution<double> g;
    std::vector<glm::dvec3> out;
    for (int i = 0; i < n; ++i) out.push_back(glm::normalize(glm::dvec3(g(rng), g(rng), g(rng))));
    return out;
}

// Residuals whose exact minimum is delta = truth: the field seen through exp(delta) against the
// field seen through the true rotation; `outlier` is added to every tenth point (a person walking
// through the view), and every seventh point is invalid (NaN, as an uncovered texel is).
RotationResiduals residuals_of(const glm::dvec3& truth, const std::vector<glm::dvec3>& points, double outlier = 0) {
    const glm::dquat q_true = rotation_from_vector(truth);
    return [=](const glm::dvec3& delta, std::vector<double>& r) {
        const glm::dquat q = rotation_from_vector(delta);
        r.assign(points.size(), 0);
        for (std::size_t i = 0; i < points.size(); ++i) {
            if (i % 7 == 3) {
                r[i] = std::nan("");
                continue;
            }
            r[i] = field(q * points[i]) - field(q_true * points[i]) + (i % 10 == 0 ? outlier : 0);
        }
    };
}

TEST(RotationFit, RecoversAKnownSmallRotation) {
    const std::vector<glm::dvec3> points = directions(600, 5);
    const glm::dvec3 truth = glm::dvec3(0.4, -0.7, 0.25) * kDeg;  // 0.84 degrees
    const RotationFit fit = fit_rotation(residuals_of(truth, points));
    const double err_deg = glm::length(fit.delta - truth) / kDeg;
    std::printf("fit_rotation, exact residuals: %.2e degrees from the true 0.84-degree rotation, sigma %.2e\n",
                err_deg, fit.sigma_rad / kDeg);
    ASSERT_TRUE(fit.estimated);
    EXPECT_EQ(fit.points, 600 - 600 / 7 - 1);  // the NaN points take no part (i % 7 == 3: 86 of them)
    // Measured 1e-7 degrees (noiseless: Gauss-Newton lands on the exact minimum); 1e-4 is margin
    // for the central differences, and still 8400 times smaller than the rotation.
    EXPECT_LT(err_deg, 1e-4);
    EXPECT_GT(fit.cost_before, 0.005);
    EXPECT_LT(fit.cost_after, 1e-6);
}

TEST(RotationFit, OutliersAreHeldOffByTheHuberCost) {
    // A tenth of the points 2.0 off (far beyond the Huber threshold of 0.3). Their gradients do
    // not cancel, so they pull the minimum away from the true rotation: plain least squares by
    // the full 2.0 per point, the Huber cost by its threshold only. The fit must keep most of
    // that pull off.
    const std::vector<glm::dvec3> points = directions(600, 6);
    const glm::dvec3 truth = glm::dvec3(-0.9, 0.3, 0.5) * kDeg;
    const RotationFit fit = fit_rotation(residuals_of(truth, points, 2.0));
    RotationFitSettings plain;
    plain.huber = 1e9;  // every residual counts quadratically
    plain.iterations = 30;
    const RotationFit ls = fit_rotation(residuals_of(truth, points, 2.0), plain);
    const double err_deg = glm::length(fit.delta - truth) / kDeg, ls_deg = glm::length(ls.delta - truth) / kDeg;
    std::printf("fit_rotation, 10 %% outliers: %.3f degrees from the true 1.07-degree rotation (least squares: %.3f)\n",
                err_deg, ls_deg);
    ASSERT_TRUE(fit.estimated);
    EXPECT_LT(err_deg, 0.4);  // measured 0.249
    EXPECT_LT(err_deg, 0.5 * ls_deg);  // measured 0.17 of least squares' 1.439 degrees
    EXPECT_LT(fit.cost_after, fit.cost_before);
}

TEST(RotationFit, TooFewPointsGiveNoEstimate) {
    const std::vector<glm::dvec3> points = directions(100, 7);  // 86 valid, min_points 150
    const RotationFit fit = fit_rotation(residuals_of(glm::dvec3(0.01, 0, 0), points));
    EXPECT_FALSE(fit.estimated);
    EXPECT_EQ(fit.points, 86);
    EXPECT_EQ(glm::length(fit.delta), 0.0);
    EXPECT_EQ(fit.cost_after, fit.cost_before);
}

// --- DriftCorrector -----------------------------------------------------------------------

// courtyard (textured in every direction the view below sees), its radiance as the sphere the
// accumulator would hold after a perfect scan, and a noiseless frame rendered from a known
// orientation with settled auto-exposure.
struct DriftScene {
    CameraCalibration cal;
    HdrImage sphere;
    std::vector<std::uint32_t> samples;
    glm::dquat truth;
    CameraFrame frame;
};

DriftScene make_scene() {
    DriftScene s;
    const HdrImage env = load_exr(std::string(GLINT_BLENDER_WORLDS) + "/courtyard.exr").image;
    SensorModel sensor;
    sensor.noise = false;
    s.cal.intrinsics = Intrinsics::from_fov(320, 180, 70 * kDeg);
    s.cal.intrinsics.k1 = -0.08;
    s.cal.intrinsics.k2 = 0.012;
    s.cal.vignetting = {-0.22, 0.03, 0};
    s.cal.sensitivity = sensor.electrons_per_radiance_second / sensor.full_well_electrons;
    s.sphere = resample_bilinear(env, 512, 256);  // the session test's map size
    s.samples.assign(std::size_t(512) * 256, 1);
    s.truth = camera_look(30, 10);
    CameraSimulator cam(env, s.cal, sensor);
    for (int k = 0; k < 6; ++k) s.frame = cam.render(s.truth, k);  // let the auto-exposure settle
    return s;
}

// The settings with fusion switched off: gain 1 carries the measured offset in full.
DriftSettings unfused() {
    DriftSettings d;
    d.gain = 1.0;
    return d;
}

TEST(DriftCorrector, RecoversAKnownOrientationError) {
    const DriftScene s = make_scene();
    // The sensor says the camera is turned 0.63 degrees away from where it is.
    const glm::dquat error = rotation_from_vector(glm::dvec3(0.3, -0.5, 0.25) * kDeg);
    const glm::dquat sensor = error * s.truth;
    DriftCorrector dc(unfused());
    const DriftEstimate e = dc.estimate(s.frame, s.cal, sensor, s.sphere, s.samples);
    const double left_deg = angle_between(e.correction * sensor, s.truth) / kDeg;
    const double to_inverse_deg = angle_between(e.correction, glm::conjugate(error)) / kDeg;
    std::printf("drift estimate of a 0.63-degree error: %.3f degrees, the corrected camera %.4f degrees from the "
                "truth (sigma %.4f, %d grid pixels, residual %.4f -> %.4f)\n",
                e.angle_deg, left_deg, e.sigma_deg, e.pixels, e.residual_before, e.residual_after);
    ASSERT_TRUE(e.applied);
    // The correction is the error's inverse (corrected = correction * world_from_camera).
    // Measured: 0.060 degrees left of the 0.63-degree error (0.044..0.068 over six errors of
    // 0.35..1 degrees; 0.040 for an aligned frame: the floor of a noiseless frame against the
    // bilinear 512x256 sphere). No correction would leave 0.63 degrees, a sign error 1.27.
    EXPECT_LT(left_deg, 0.12);
    EXPECT_LT(to_inverse_deg, 0.12);
    EXPECT_NEAR(e.angle_deg, angle_between(error, glm::dquat(1, 0, 0, 0)) / kDeg, 0.12);  // 0.614 of 0.634
    EXPECT_LT(e.residual_after, e.residual_before);
    EXPECT_GT(e.pixels, 150);
    EXPECT_LT(e.sigma_deg, DriftSettings{}.max_sigma_deg);
    // Without fusion the carried correction is this frame's.
    EXPECT_LT(angle_between(dc.carried(), e.correction) / kDeg, 1e-9);
}

TEST(DriftCorrector, AnAlignedFrameNeedsNoCorrection) {
    const DriftScene s = make_scene();
    DriftCorrector dc(unfused());
    const DriftEstimate e = dc.estimate(s.frame, s.cal, s.truth, s.sphere, s.samples);
    std::printf("drift estimate of an aligned frame: %.4f degrees\n", e.angle_deg);
    EXPECT_LT(e.angle_deg, 0.1);  // measured 0.040 (the noiseless frame against the bilinear sphere)
}

TEST(DriftCorrector, FusesTheMeasuredOffsetWithItsGains) {
    // Default fusion (gain 0.1, frame_share 0.6) after one trusted frame: the carried part is a
    // tenth of the measured offset, this frame's correction 0.1 + 0.6 * 0.9 = 0.64 of it, both
    // along the same axis.
    const DriftScene s = make_scene();
    const glm::dquat error = rotation_from_vector(glm::dvec3(0.0, 0.8, 0.0) * kDeg);
    const glm::dquat sensor = error * s.truth;
    const DriftEstimate measured = DriftCorrector(unfused()).estimate(s.frame, s.cal, sensor, s.sphere, s.samples);
    ASSERT_TRUE(measured.applied);
    const glm::dvec3 m = rotation_vector(measured.correction);
    DriftCorrector dc;
    const DriftEstimate e = dc.estimate(s.frame, s.cal, sensor, s.sphere, s.samples);
    ASSERT_TRUE(e.applied);
    EXPECT_LT(glm::length(rotation_vector(dc.carried()) - 0.1 * m) / kDeg, 1e-6);
    EXPECT_LT(glm::length(rotation_vector(e.correction) - 0.64 * m) / kDeg, 1e-6);
    // A second, identical frame: the carried part moves another tenth of the way.
    dc.estimate(s.frame, s.cal, sensor, s.sphere, s.samples);
    EXPECT_LT(glm::length(rotation_vector(dc.carried()) - 0.19 * m) / kDeg, 1e-6);
}

TEST(DriftCorrector, DoesNotTrustWhatItCannotMeasure) {
    const DriftScene s = make_scene();
    const glm::dquat error = rotation_from_vector(glm::dvec3(0.3, -0.5, 0.25) * kDeg);
    // Nothing covered yet: no pixels, no correction, nothing carried.
    DriftCorrector empty;
    const DriftEstimate none =
        empty.estimate(s.frame, s.cal, error * s.truth, s.sphere, std::vector<std::uint32_t>(s.samples.size(), 0));
    EXPECT_FALSE(none.applied);
    EXPECT_EQ(none.pixels, 0);
    EXPECT_EQ(angle_between(none.correction, glm::dquat(1, 0, 0, 0)), 0.0);
    EXPECT_EQ(angle_between(empty.carried(), glm::dquat(1, 0, 0, 0)), 0.0);
    // A frame 6 degrees off: beyond what the fit can reach from no correction (measured: it
    // stops 0.9 degrees along with a sigma of 0.06, over max_sigma_deg 0.02, and so at 3.5, 4
    // and 5 degrees), so it is not applied, and the carried correction stays where it was.
    DriftCorrector far(unfused());
    const glm::dquat big = rotation_from_vector(glm::dvec3(0, 6, 0) * kDeg);
    const DriftEstimate e = far.estimate(s.frame, s.cal, big * s.truth, s.sphere, s.samples);
    EXPECT_FALSE(e.applied);
    EXPECT_EQ(angle_between(e.correction, glm::dquat(1, 0, 0, 0)), 0.0);
    EXPECT_EQ(angle_between(far.carried(), glm::dquat(1, 0, 0, 0)), 0.0);
    // A well-measured offset beyond max_correction_deg is not trusted either: the 0.63-degree
    // error above (estimated 0.61, sigma 0.006) against a limit of 0.3 degrees.
    DriftSettings tight = unfused();
    tight.max_correction_deg = 0.3;
    DriftCorrector limited(tight);
    const DriftEstimate over = limited.estimate(s.frame, s.cal, error * s.truth, s.sphere, s.samples);
    EXPECT_FALSE(over.applied);
    EXPECT_GT(over.angle_deg, 0.3);  // it was measured, then refused
    EXPECT_EQ(angle_between(over.correction, glm::dquat(1, 0, 0, 0)), 0.0);
    EXPECT_EQ(angle_between(limited.carried(), glm::dquat(1, 0, 0, 0)), 0.0);
}

}  // namespace
}  // namespace glint::capture
