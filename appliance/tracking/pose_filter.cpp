#include "appliance/tracking/pose_filter.hpp"

#include <cmath>
#include <numbers>

namespace glint::tracking {
namespace {

double alpha(double cutoff_hz, double dt) { return 1.0 / (1.0 + 1.0 / (2 * std::numbers::pi * cutoff_hz * dt)); }

}  // namespace

Pose PoseFilter::update(double t, const Pose& measured) {
    if (!last_t_ || !(t > *last_t_)) {
        const bool same_time = last_t_ && t == *last_t_;
        last_t_ = t;
        if (!same_time) {
            filtered_ = {unit_rotation(measured.rotation), measured.translation};
            rot_velocity_ = glm::dvec3(0);
            trans_speed_ = glm::dvec3(0);
        }
        return filtered_;
    }
    const double dt = t - *last_t_;
    last_t_ = t;
    // Rotation: the step from the filtered rotation to the measurement, in the camera frame.
    const glm::dvec3 step = rotation_vector(unit_rotation(measured.rotation * glm::conjugate(filtered_.rotation)));
    const OneEuroParams& r = params_.rotation;
    const double ad = alpha(r.d_cutoff_hz, dt);
    rot_velocity_ += ad * (step / dt - rot_velocity_);
    const double ar = alpha(r.min_cutoff_hz + r.beta * glm::length(rot_velocity_), dt);
    filtered_.rotation = unit_rotation(rotation_from_vector(ar * step) * filtered_.rotation);
    // Translation, per component.
    const OneEuroParams& p = params_.translation;
    const glm::dvec3 delta = measured.translation - filtered_.translation;
    trans_speed_ += alpha(p.d_cutoff_hz, dt) * (delta / dt - trans_speed_);
    for (int i = 0; i < 3; ++i) {
        const double at = alpha(p.min_cutoff_hz + p.beta * std::abs(trans_speed_[i]), dt);
        filtered_.translation[i] += at * delta[i];
    }
    return filtered_;
}

}  // namespace glint::tracking
