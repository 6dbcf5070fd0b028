// A small rotation that minimises a set of photometric residuals, by Gauss-Newton with central
// differences and a Huber-like cost. Shared by the drift correction (a frame against the sphere)
// and the pairwise alignment of the global adjustment (a frame against another frame).
#pragma once

#include <functional>
#include <vector>

#include <glm/glm.hpp>

namespace glint::capture {

struct RotationFitSettings {
    int iterations = 8;
    int min_points = 150;    // fewer valid residuals: no estimate
    double huber = 0.3;      // residuals beyond count linearly (a moving person, a glint)
    double step_rad = 0.0005;  // central-difference step, about a tenth of a texel of a 1024-wide map
};

struct RotationFit {
    glm::dvec3 delta{0};  // the rotation vector found (radians), in the residuals' frame
    // Information of the estimate (inverse covariance, rad^-2): J^T W J / s^2 at the solution,
    // with s^2 the mean squared residual (symmetric). Zero when nothing was estimated.
    glm::dmat3 information{0};
    double sigma_rad = 1e9;  // per-axis standard deviation, sqrt(trace(covariance) / 3)
    double cost_before = 0, cost_after = 0;  // RMS (Huber) of the residuals at 0 and at delta
    int points = 0;          // valid residuals at 0
    bool estimated = false;  // enough points and a solvable system
};

// residuals(delta, r) sets r (one value per point, NaN where the point is not valid at delta).
using RotationResiduals = std::function<void(const glm::dvec3& delta, std::vector<double>& r)>;

RotationFit fit_rotation(const RotationResiduals& residuals, const RotationFitSettings& settings = {});

}  // namespace glint::capture
