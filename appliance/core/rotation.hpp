// Rotations in the appliance are GLM's, in double: glm::dquat, glm::dvec3, glm::dmat3. This holds
// what GLM does not have. GLM's habits, for the reader: glm::dquat(w, x, y, z) takes w first
// (it stores x, y, z, w); q * v rotates v; glm::slerp (gtc/quaternion.hpp) takes the short way;
// glm::mat3_cast and glm::quat_cast convert to and from column-major matrices (m[column][row]).
// The sensor side keeps its own freestanding maths (firmware_bridge/firmware/rotation.hpp); its
// quaternions become GLM's once, in firmware_bridge/host (host::to_glm).
#pragma once

#include <algorithm>
#include <cmath>
#include <glm/glm.hpp>
#include <glm/gtc/quaternion.hpp>

namespace glint {

// The unit quaternion with w >= 0 of q (q and -q are one rotation; one sign keeps files and
// comparisons stable). A zero or non-finite input gives the identity.
inline glm::dquat unit_rotation(const glm::dquat& q) {
    const double n = glm::length(q);
    if (!(n > 0) || !std::isfinite(n)) return glm::dquat(1, 0, 0, 0);
    return q * ((q.w < 0 ? -1.0 : 1.0) / n);
}

// Rotation vector (axis * angle, angle in 0 .. pi), the log map: q taken with w >= 0 is
// (cos(angle/2), sin(angle/2) axis), so angle = 2 atan2(|vec|, w), whatever q's length.
inline glm::dvec3 rotation_vector(const glm::dquat& q) {
    const glm::dvec3 v = q.w < 0 ? -glm::dvec3(q.x, q.y, q.z) : glm::dvec3(q.x, q.y, q.z);
    const double s = glm::length(v);
    if (s < 1e-15) return glm::dvec3(0);
    return v * (2 * std::atan2(s, std::abs(q.w)) / s);
}

// Its inverse, the exp map: the rotation by |v| about v / |v|.
inline glm::dquat rotation_from_vector(const glm::dvec3& v) {
    const double angle = glm::length(v);
    if (angle < 1e-15) return glm::dquat(1, 0, 0, 0);
    return glm::angleAxis(angle, v / angle);
}

// rotation_from_vector(r) * v without building the quaternion (Rodrigues' formula):
//   v + a (r x v) + b r x (r x v),  a = sin(t) / t,  b = (1 - cos(t)) / t^2,  t = |r|.
// Below t = 0.05 rad (a rolling shutter's row turn is a few milliradians) a and b come from their
// series in t^2, whose first dropped terms are t^8 / 9! and t^8 / 10! (< 2e-16 there): no sine,
// cosine or square root, which the accumulation's per-tap projections spent most of their time in.
inline glm::dvec3 rotate_by_vector(const glm::dvec3& r, const glm::dvec3& v) {
    const double t2 = glm::dot(r, r);
    double a, b;
    if (t2 < 0.05 * 0.05) {
        a = 1 - t2 / 6 * (1 - t2 / 20 * (1 - t2 / 42));
        b = 0.5 * (1 - t2 / 12 * (1 - t2 / 30 * (1 - t2 / 56)));
    } else {
        const double t = std::sqrt(t2);
        a = std::sin(t) / t;
        b = (1 - std::cos(t)) / t2;
    }
    const glm::dvec3 rv = glm::cross(r, v);
    return v + a * rv + b * glm::cross(r, rv);
}

// Angle of the rotation taking a to b (0 .. pi), for unit quaternions: the rotation b a* has
// w = dot(a, b) = cos(angle/2), up to sign.
inline double angle_between(const glm::dquat& a, const glm::dquat& b) {
    return 2 * std::acos(std::min(1.0, std::abs(glm::dot(a, b))));
}

}  // namespace glint
