#include "appliance/capture/drift_correction.hpp"

#include <algorithm>
#include <cmath>

#include "appliance/capture/hdr_accumulator.hpp"
#include "appliance/core/equirect.hpp"

namespace glint::capture {

Quatd rotation_from_vector(const firmware::Vec3d& v) {
    const double angle = std::sqrt(v.x * v.x + v.y * v.y + v.z * v.z);
    if (angle < 1e-15) return Quatd::identity();
    return Quatd::from_axis_angle({v.x / angle, v.y / angle, v.z / angle}, angle);
}

firmware::Vec3d rotation_vector_of(Quatd q) {
    if (q.w < 0) q = {-q.w, -q.x, -q.y, -q.z};
    const double s = std::sqrt(q.x * q.x + q.y * q.y + q.z * q.z);
    if (s < 1e-15) return {};
    const double angle = 2 * std::atan2(s, q.w);
    return {q.x / s * angle, q.y / s * angle, q.z / s * angle};
}

namespace {

struct GridPixel {
    firmware::Vec3d ray;  // camera frame
    double log_lum;       // log luminance of the frame's radiance estimate
};

}  // namespace

DriftEstimate DriftCorrector::estimate(const CameraFrame& frame, const CameraCalibration& cal,
                                       const Quatd& world_from_camera, const HdrImage& sphere,
                                       const std::vector<std::uint32_t>& samples) {
    DriftEstimate out = measure(frame, cal, world_from_camera, sphere, samples);
    if (!out.applied) return out;  // not trusted: keep the previous correction
    // Low-pass of the measured offset: a slowly growing sensor drift is followed in full, while the
    // noise of single alignments averages out instead of being applied (or chained) frame by frame.
    const Quatd measured = out.correction;
    carried_ = firmware::normalized(firmware::slerp(carried_, measured, settings_.gain));
    // This frame: the slow part, plus a share of what this frame's own alignment says beyond it.
    out.correction = firmware::normalized(firmware::slerp(carried_, measured, settings_.frame_share));
    return out;
}

DriftEstimate DriftCorrector::measure(const CameraFrame& frame, const CameraCalibration& cal,
                                      const Quatd& world_from_camera, const HdrImage& sphere,
                                      const std::vector<std::uint32_t>& samples) const {
    DriftEstimate out;
    const Intrinsics& k = cal.intrinsics;
    // The frame is sampled exactly as the accumulator samples it (box filtered by the same factor
    // for this map size, then read bilinearly), at grid points every `stride` pixels: frame and
    // sphere values then carry the same blur, and detail does not bias the alignment.
    const int w = sphere.width(), h = sphere.height();
    const int s = HdrAccumulator::auto_downscale(k, w);
    const int stride = std::max(1, k.width / settings_.grid_width);
    int pw = 0, ph = 0;
    const std::vector<float> planes = HdrAccumulator::filtered_planes(frame, cal, s, pw, ph);
    const double t = frame.exposure_s * frame.total_gain() * cal.sensitivity;
    std::vector<GridPixel> grid;
    for (int pv = stride / 2; pv < k.height; pv += stride)
        for (int pu = stride / 2; pu < k.width; pu += stride) {
            double P[HdrAccumulator::kPlaneFloats];
            HdrAccumulator::sample_planes(planes, pw, ph, HdrAccumulator::grid_coordinate(pu, s),
                                          HdrAccumulator::grid_coordinate(pv, s), P);
            double lum = 0;
            bool ok = P[6] == 0;  // beside a clipped pixel the value is only a lower bound
            for (int c = 0; c < 3; ++c) {
                if (!(P[3 + c] > 0.05)) ok = false;  // mostly clipped or black: no reliable value
                else lum += P[c] / t;
            }
            if (!ok || !(lum > 0)) continue;
            const Vec3 r = pixel_ray(k, pu, pv);
            grid.push_back({{r.x, r.y, r.z}, std::log(lum / 3)});
        }
    // Residuals of a candidate world-frame correction; pixels whose texel is not covered drop out.
    const auto residuals = [&](const firmware::Vec3d& delta, std::vector<double>& r) {
        const Quatd q = rotation_from_vector(delta) * world_from_camera;
        r.assign(grid.size(), std::nan(""));
        for (std::size_t i = 0; i < grid.size(); ++i) {
            const firmware::Vec3d d = q.rotate(grid[i].ray);
            const TexelCoord tc = direction_to_texel({d.x, d.y, d.z}, w, h);
            const int ti = std::clamp(int(tc.x), 0, w - 1), tj = std::clamp(int(tc.y), 0, h - 1);
            if (samples[std::size_t(tj) * std::size_t(w) + std::size_t(ti)] == 0) continue;
            const Rgb e = sample_bilinear(sphere, {d.x, d.y, d.z});
            const double lum = (double(e.r) + double(e.g) + double(e.b)) / 3;
            if (!(lum > 0)) continue;
            r[i] = grid[i].log_lum - std::log(lum);
        }
    };
    // Cost over the pixels valid for every evaluation of an iteration (same set when comparing).
    const auto rms = [](const std::vector<double>& r, const std::vector<char>& use, int& n) {
        double sum = 0;
        n = 0;
        for (std::size_t i = 0; i < r.size(); ++i)
            if (use[i]) {
                // Huber-like: a pixel far off (a moving person, a specular glint) counts linearly.
                const double a = std::abs(r[i]);
                sum += a < 0.3 ? a * a : 0.3 * (2 * a - 0.3);
                ++n;
            }
        return n > 0 ? std::sqrt(sum / n) : 0.0;
    };

    firmware::Vec3d delta{};  // every frame is measured from the orientation it is given
    std::vector<double> r0, rp, rm;
    residuals(delta, r0);
    std::vector<char> use(grid.size());
    for (std::size_t i = 0; i < grid.size(); ++i) use[i] = std::isfinite(r0[i]);
    int n = 0;
    out.residual_before = rms(r0, use, n);
    out.pixels = n;
    if (n < settings_.min_pixels) {
        out.residual_after = out.residual_before;
        return out;
    }
    const double h_step = 0.0005;  // rad, about a tenth of a texel of a 1024-wide map
    double cost = out.residual_before;
    double sigma_rad = 1e9;  // uncertainty of the estimate (from the last normal equations)
    for (int it = 0; it < settings_.iterations; ++it) {
        // Jacobian by central differences; only pixels valid in all evaluations take part.
        std::vector<std::array<double, 3>> J(grid.size());
        std::vector<char> ok = use;
        for (int a = 0; a < 3; ++a) {
            firmware::Vec3d dp = delta, dm = delta;
            (a == 0 ? dp.x : a == 1 ? dp.y : dp.z) += h_step;
            (a == 0 ? dm.x : a == 1 ? dm.y : dm.z) -= h_step;
            residuals(dp, rp);
            residuals(dm, rm);
            for (std::size_t i = 0; i < grid.size(); ++i) {
                if (!ok[i] || !std::isfinite(rp[i]) || !std::isfinite(rm[i])) {
                    ok[i] = 0;
                    continue;
                }
                J[i][std::size_t(a)] = (rp[i] - rm[i]) / (2 * h_step);
            }
        }
        double A[3][3] = {}, b[3] = {};
        for (std::size_t i = 0; i < grid.size(); ++i) {
            if (!ok[i]) continue;
            const double wgt = std::abs(r0[i]) < 0.3 ? 1.0 : 0.3 / std::abs(r0[i]);
            for (int p = 0; p < 3; ++p) {
                b[p] -= wgt * J[i][std::size_t(p)] * r0[i];
                for (int q = 0; q < 3; ++q) A[p][q] += wgt * J[i][std::size_t(p)] * J[i][std::size_t(q)];
            }
        }
        for (int p = 0; p < 3; ++p) A[p][p] *= 1.01;  // a little damping (Levenberg)
        // Solve the 3x3 system by Cramer's rule.
        const auto det3 = [](const double m[3][3]) {
            return m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1]) - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0]) +
                   m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0]);
        };
        const double D = det3(A);
        if (!(std::abs(D) > 1e-30)) break;
        {
            // Covariance of delta ~ s^2 (J^T J)^-1 with s^2 the mean squared residual: the trace of
            // the inverse from the cofactors' diagonal.
            double sr = 0;
            int nr = 0;
            for (std::size_t i = 0; i < grid.size(); ++i)
                if (ok[i]) {
                    sr += r0[i] * r0[i];
                    ++nr;
                }
            const double c00 = A[1][1] * A[2][2] - A[1][2] * A[2][1];
            const double c11 = A[0][0] * A[2][2] - A[0][2] * A[2][0];
            const double c22 = A[0][0] * A[1][1] - A[0][1] * A[1][0];
            const double trace_inv = (c00 + c11 + c22) / D;
            if (nr > 0 && trace_inv > 0) sigma_rad = std::sqrt(sr / nr * trace_inv / 3);
        }
        double step[3];
        for (int c = 0; c < 3; ++c) {
            double M[3][3];
            for (int p = 0; p < 3; ++p)
                for (int q = 0; q < 3; ++q) M[p][q] = q == c ? b[p] : A[p][q];
            step[c] = det3(M) / D;
        }
        const firmware::Vec3d next{delta.x + step[0], delta.y + step[1], delta.z + step[2]};
        std::vector<double> rn;
        residuals(next, rn);
        std::vector<char> both(grid.size());
        for (std::size_t i = 0; i < grid.size(); ++i) both[i] = use[i] && std::isfinite(rn[i]);
        int n_old = 0, n_new = 0;
        const double c_old = rms(r0, both, n_old), c_new = rms(rn, both, n_new);
        if (!(c_new < c_old) || n_new < settings_.min_pixels) break;
        delta = next;
        r0 = rn;
        use = both;
        cost = c_new;
        if (std::sqrt(step[0] * step[0] + step[1] * step[1] + step[2] * step[2]) < 1e-5) break;
    }
    const double angle = std::sqrt(delta.x * delta.x + delta.y * delta.y + delta.z * delta.z);
    out.angle_deg = angle * 180.0 / kPi;
    out.residual_after = cost;
    out.sigma_deg = sigma_rad * 180.0 / kPi;
    if (out.angle_deg > settings_.max_correction_deg || !(cost <= out.residual_before) ||
        out.sigma_deg > settings_.max_sigma_deg) {
        out.residual_after = out.residual_before;
        return out;  // not trusted
    }
    out.correction = rotation_from_vector(delta);
    out.applied = true;
    return out;
}

}  // namespace glint::capture
