#include "appliance/capture/rotation_fit.hpp"

#include <array>
#include <cmath>

namespace glint::capture {

namespace {

double det3(const double m[3][3]) {
    return m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1]) - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0]) +
           m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0]);
}

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
    firmware::Vec3d delta{};
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
        std::vector<std::array<double, 3>> J(n_points);
        std::vector<char> ok = use;
        for (int a = 0; a < 3; ++a) {
            firmware::Vec3d dp = delta, dm = delta;
            (a == 0 ? dp.x : a == 1 ? dp.y : dp.z) += h;
            (a == 0 ? dm.x : a == 1 ? dm.y : dm.z) -= h;
            residuals(dp, rp);
            residuals(dm, rm);
            for (std::size_t i = 0; i < n_points; ++i) {
                if (!ok[i] || !std::isfinite(rp[i]) || !std::isfinite(rm[i])) {
                    ok[i] = 0;
                    continue;
                }
                J[i][std::size_t(a)] = (rp[i] - rm[i]) / (2 * h);
            }
        }
        double A[3][3] = {}, b[3] = {};
        double sr = 0;
        int nr = 0;
        for (std::size_t i = 0; i < n_points; ++i) {
            if (!ok[i]) continue;
            const double wgt = std::abs(r0[i]) < settings.huber ? 1.0 : settings.huber / std::abs(r0[i]);
            for (int p = 0; p < 3; ++p) {
                b[p] -= wgt * J[i][std::size_t(p)] * r0[i];
                for (int q = 0; q < 3; ++q) A[p][q] += wgt * J[i][std::size_t(p)] * J[i][std::size_t(q)];
            }
            sr += r0[i] * r0[i];
            ++nr;
        }
        if (nr == 0) break;
        // Covariance ~ s^2 (J^T J)^-1: its trace from the cofactors' diagonal; the information
        // is the inverse, A / s^2.
        const double s2 = sr / nr;
        const double D0 = det3(A);
        if (!(std::abs(D0) > 1e-30)) break;
        const double trace_inv = (A[1][1] * A[2][2] - A[1][2] * A[2][1] + A[0][0] * A[2][2] - A[0][2] * A[2][0] +
                                  A[0][0] * A[1][1] - A[0][1] * A[1][0]) /
                                 D0;
        if (trace_inv > 0) out.sigma_rad = std::sqrt(s2 * trace_inv / 3);
        for (int p = 0; p < 3; ++p)
            for (int q = 0; q < 3; ++q) out.information[p][q] = s2 > 0 ? A[p][q] / s2 : 0;
        out.estimated = true;
        // Levenberg-Marquardt: a step that does not lower the cost is retried with more damping
        // (a shorter step towards the gradient). Along a weakly constrained direction the plain
        // Gauss-Newton step overshoots, and stopping there left the estimate at its start.
        bool improved = false;
        double step_length = 0;
        for (int attempt = 0; attempt < 6 && !improved; ++attempt, lambda *= 10) {
            double M0[3][3];
            for (int p = 0; p < 3; ++p)
                for (int q = 0; q < 3; ++q) M0[p][q] = A[p][q] * (p == q ? 1 + lambda : 1.0);
            const double D = det3(M0);
            if (!(std::abs(D) > 1e-30)) continue;
            double step[3];
            for (int c = 0; c < 3; ++c) {
                double M[3][3];
                for (int p = 0; p < 3; ++p)
                    for (int q = 0; q < 3; ++q) M[p][q] = q == c ? b[p] : M0[p][q];
                step[c] = det3(M) / D;
            }
            const firmware::Vec3d next{delta.x + step[0], delta.y + step[1], delta.z + step[2]};
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
            step_length = std::sqrt(step[0] * step[0] + step[1] * step[1] + step[2] * step[2]);
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
