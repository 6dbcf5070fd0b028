#include "appliance/capture/rotation_fit.hpp"

#include <cmath>

namespace glint::capture {

namespace {

// Cost over the points valid for every evaluation being compared (the same set on both sides).
double huber_rms(const std::vector<double>& r, const std::vector<char>& use, double k, int& n) {
    double sum = 0;
    n = 0;
    for (std::size_t i = 0; i < r.size(); ++i)
        if (use[i]) {
            const double a = std::abs(r[i]);
            sum += a < k ? a * a : k * (2 * a - k);
            ++n;
        }
    return n > 0 ? std::sqrt(sum / n) : 0.0;
}

}  // namespace

RotationFit fit_rotation(const RotationResiduals& residuals, const RotationFitSettings& settings) {
    RotationFit out;
    glm::dvec3 delta(0);
    std::vector<double> r0, rp, rm;
    residuals(delta, r0);
    const std::size_t n_points = r0.size();
    std::vector<char> use(n_points);
    for (std::size_t i = 0; i < n_points; ++i) use[i] = std::isfinite(r0[i]);
    int n = 0;
    out.cost_before = huber_rms(r0, use, settings.huber, n);
    out.cost_after = out.cost_before;
    out.points = n;
    if (n < settings.min_points) return out;
    const double h = settings.step_rad;
    double cost = out.cost_before;
    double lambda = 0.01;  // Levenberg-Marquardt damping, relative to the diagonal
    for (int it = 0; it < settings.iterations; ++it) {
        // Jacobian by central differences; only points valid in all evaluations take part.
        std::vector<glm::dvec3> J(n_points);
        std::vector<char> ok = use;
        for (int a = 0; a < 3; ++a) {
            glm::dvec3 dp = delta, dm = delta;
            dp[a] += h;
            dm[a] -= h;
            residuals(dp, rp);
            residuals(dm, rm);
            for (std::size_t i = 0; i < n_points; ++i) {
                if (!ok[i] || !std::isfinite(rp[i]) || !std::isfinite(rm[i])) {
                    ok[i] = 0;
                    continue;
                }
                J[i][a] = (rp[i] - rm[i]) / (2 * h);
            }
        }
        // The normal equations A step = b (A symmetric, so row or column order does not matter).
        glm::dmat3 A(0);
        glm::dvec3 b(0);
        double sr = 0;
        int nr = 0;
        for (std::size_t i = 0; i < n_points; ++i) {
            if (!ok[i]) continue;
            const double wgt = std::abs(r0[i]) < settings.huber ? 1.0 : settings.huber / std::abs(r0[i]);
            for (int p = 0; p < 3; ++p) {
                b[p] -= wgt * J[i][p] * r0[i];
                for (int q = 0; q < 3; ++q) A[p][q] += wgt * J[i][p] * J[i][q];
            }
            sr += r0[i] * r0[i];
            ++nr;
        }
        if (nr == 0) break;
        // Covariance ~ s^2 (J^T J)^-1: its trace from the cofactors' diagonal; the information
        // is the inverse, A / s^2.
        const double s2 = sr / nr;
        const double D0 = glm::determinant(A);
        if (!(std::abs(D0) > 1e-30)) break;
        const double trace_inv = (A[1][1] * A[2][2] - A[1][2] * A[2][1] + A[0][0] * A[2][2] - A[0][2] * A[2][0] +
                                  A[0][0] * A[1][1] - A[0][1] * A[1][0]) /
                                 D0;
        if (trace_inv > 0) out.sigma_rad = std::sqrt(s2 * trace_inv / 3);
        out.information = s2 > 0 ? A / s2 : glm::dmat3(0);
        out.estimated = true;
        // Levenberg-Marquardt: a step that does not lower the cost is retried with more damping
        // (a shorter step towards the gradient). Along a weakly constrained direction the plain
        // Gauss-Newton step overshoots, and stopping there left the estimate at its start.
        bool improved = false;
        double step_length = 0;
        for (int attempt = 0; attempt < 6 && !improved; ++attempt, lambda *= 10) {
            glm::dmat3 M0 = A;
            for (int p = 0; p < 3; ++p) M0[p][p] *= 1 + lambda;
            const double D = glm::determinant(M0);
            if (!(std::abs(D) > 1e-30)) continue;
            // Cramer's rule: step[c] = det(M0 with column c replaced by b) / det(M0).
            glm::dvec3 step(0);
            for (int c = 0; c < 3; ++c) {
                glm::dmat3 M = M0;
                M[c] = b;
                step[c] = glm::determinant(M) / D;
            }
            const glm::dvec3 next = delta + step;
            std::vector<double> rn;
            residuals(next, rn);
            std::vector<char> both(n_points);
            for (std::size_t i = 0; i < n_points; ++i) both[i] = use[i] && std::isfinite(rn[i]);
            int n_old = 0, n_new = 0;
            const double c_old = huber_rms(r0, both, settings.huber, n_old), c_new = huber_rms(rn, both, settings.huber, n_new);
            if (!(c_new < c_old) || n_new < settings.min_points) continue;
            delta = next;
            r0 = rn;
            use = both;
            cost = c_new;
            improved = true;
            step_length = glm::length(step);
        }
        if (!improved) break;
        lambda = std::max(1e-3, lambda / 30);  // undo the last increase, then relax
        if (step_length < 1e-5) break;
    }
    out.delta = delta;
    out.cost_after = cost;
    return out;
}

}  // namespace glint::capture
