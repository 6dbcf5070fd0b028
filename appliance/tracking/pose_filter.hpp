// The One Euro filter on the board pose (docs/tracking.md "Filter"): a first-order low-pass whose
// cut-off rises with the speed, so a still pose is smoothed hard and a moving one followed
// closely (Casiez, Roussel, Vogel, CHI 2012). Translation: per component. Rotation: the step from
// the filtered rotation to the new measurement as a rotation vector, of which the filter takes
// the fraction alpha (a slerp with the One Euro alpha); the speed is the length of that step per
// second, low-passed as a vector (so the steps of noise cancel, those of a turn add up).
//   alpha(fc, dt) = 1 / (1 + 1 / (2 pi fc dt)),  fc = min_cutoff + beta |speed|, speed low-passed
//   at d_cutoff.
#pragma once

#include <optional>

#include "appliance/tracking/camera.hpp"

namespace glint::tracking {

struct OneEuroParams {
    double min_cutoff_hz = 1.0;
    double beta = 1.0;          // Hz per unit of speed (rad/s or m/s)
    double d_cutoff_hz = 1.0;   // low-pass of the speed estimate
};

struct PoseFilterParams {
    OneEuroParams rotation{0.3, 30.0, 1.0};      // speed in rad/s
    OneEuroParams translation{0.3, 40.0, 1.0};   // speed in m/s
};

class PoseFilter {
public:
    explicit PoseFilter(PoseFilterParams params = {}) : params_(params) {}
    // The filtered pose after a measurement at time t (seconds, increasing).
    Pose update(double t, const Pose& measured);
    void reset() { last_t_.reset(); }
    bool started() const { return last_t_.has_value(); }

private:
    PoseFilterParams params_;
    std::optional<double> last_t_;
    Pose filtered_;
    glm::dvec3 rot_velocity_{0};  // rad/s, low-passed: noise averages out, a turn does not
    glm::dvec3 trans_speed_{0};
};

}  // namespace glint::tracking
