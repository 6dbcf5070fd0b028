// Tests of core/rotation.hpp's helpers that GLM does not have.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include "appliance/core/rotation.hpp"

namespace glint {
namespace {

// rotate_by_vector (series below 0.05 rad, trigonometry above) against the quaternion it
// replaces, on both sides of the switch and far from it, about skew axes.
TEST(Rotation, RotateByVectorMatchesTheQuaternionOnBothSidesOfTheSeries) {
    const glm::dvec3 axes[] = {glm::normalize(glm::dvec3(1, 2, 3)), glm::normalize(glm::dvec3(-0.3, 0.1, 0.9)),
                               glm::dvec3(0, 0, 1)};
    const glm::dvec3 v(0.6, -0.48, 0.64);  // a unit vector
    const double angles[] = {0.0, 1e-12, 1e-6, 3e-3, 0.02, 0.0499999, 0.0500001, 0.3, 1.0, 3.0};
    for (const glm::dvec3& axis : axes)
        for (double angle : angles) {
            const glm::dvec3 r = axis * angle;
            const glm::dvec3 expected = rotation_from_vector(r) * v;
            const glm::dvec3 got = rotate_by_vector(r, v);
            // A few ulps of the largest intermediate (r x (r x v) is |r|^2 long), for builds that
            // fuse multiply-adds too.
            const double tolerance = 2e-15 * std::max(1.0, angle * angle);
            for (int c = 0; c < 3; ++c) EXPECT_NEAR(got[c], expected[c], tolerance) << "angle " << angle;
            EXPECT_NEAR(glm::length(got), 1.0, tolerance) << "angle " << angle;
        }
}

// The series' coefficients against sin(t) / t and (1 - cos t) / t^2 in long double: a quarter turn of
// an orthogonal vector reads a (the r x v part) and b (the r x (r x v) part) off separately.
TEST(Rotation, RotateByVectorSeriesMatchesItsFunctions) {
    for (long double t : {1e-4L, 0.01L, 0.03L, 0.0499L}) {
        const glm::dvec3 got = rotate_by_vector(glm::dvec3(0, 0, double(t)), glm::dvec3(1, 0, 0));
        // rotation about z: (cos t, sin t, 0) = (1 - b t^2, a t, 0)
        const long double a = sinl(t) / t, b = (1 - cosl(t)) / (t * t);
        EXPECT_NEAR(double((got.y / t) / a - 1), 0.0, 4e-16) << "t " << double(t);
        EXPECT_NEAR(double(((1 - (long double)got.x) / (t * t)) / b - 1), 0.0, 2e-16 / double(t * t) + 4e-16) << "t " << double(t);
    }
}

// The series' truncation: a rotation by 0.049 rad turns v by exactly that angle (to 1e-15).
TEST(Rotation, RotateByVectorTurnsByTheVectorsLength) {
    const glm::dvec3 axis(0, 1, 0), v(1, 0, 0);
    for (double angle : {1e-4, 0.01, 0.049}) {
        const glm::dvec3 got = rotate_by_vector(axis * angle, v);
        EXPECT_NEAR(std::atan2(-got.z, got.x), angle, 1e-15);
        EXPECT_NEAR(got.y, 0.0, 1e-18);
    }
}

}  // namespace
}  // namespace glint
