// Tests of core/rotation.hpp's helpers that GLM does not have.
#include <gtest/gtest.h>

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
            for (int c = 0; c < 3; ++c) EXPECT_NEAR(got[c], expected[c], 4e-16) << "angle " << angle;
            EXPECT_NEAR(glm::length(got), 1.0, 4e-16) << "angle " << angle;
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
