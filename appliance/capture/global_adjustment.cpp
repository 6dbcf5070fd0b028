#include "appliance/capture/global_adjustment.hpp"

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cmath>
#include <opencv2/core.hpp>

#include "appliance/capture/hdr_accumulator.hpp"
#include "appliance/capture/rotation_fit.hpp"
#include "appliance/core/equirect.hpp"
#include "appliance/core/errors.hpp"
#include "appliance/core/parallel.hpp"

namespace glint::capture {

namespace {

// Bilinear read of a view's cells at cell coordinates (U, V); NaN outside or beside an invalid cell.
double read_cells(const AlignmentView& v, double U, double V) {
    if (!(U >= 0 && V >= 0 && U <= v.cells_w - 1 && V <= v.cells_h - 1)) return std::nan("");
    const int u0 = std::min(int(U), v.cells_w - 2), v0 = std::min(int(V), v.cells_h - 2);
    const double fu = U - u0, fv = V - v0;
    const float* p = v.log_lum.data() + std::size_t(v0) * std::size_t(v.cells_w) + std::size_t(u0);
    const float a = p[0], b = p[1], c = p[v.cells_w], d = p[v.cells_w + 1];
    return (1 - fv) * ((1 - fu) * a + fu * b) + fv * ((1 - fu) * c + fu * d);  // NaN propagates
}

double deg(double rad) { return rad * 180.0 / kPi; }

}  // namespace

AlignmentView make_alignment_view(const CameraFrame& frame, const CameraCalibration& cal, int grid_width, int s) {
    AlignmentView v;
    v.intrinsics = cal.intrinsics;
    const Intrinsics& k = cal.intrinsics;
    v.s = s;
    const std::vector<float> planes = HdrAccumulator::filtered_planes(frame, cal, v.s, v.cells_w, v.cells_h);
    const double t = frame.exposure_s * frame.total_gain() * cal.sensitivity;
    v.log_lum.assign(std::size_t(v.cells_w) * std::size_t(v.cells_h), std::nanf(""));

    constexpr std::size_t n = HdrAccumulator::kPlaneFloats;
    for (std::size_t c = 0; c < v.log_lum.size(); ++c) {
        const float* p = planes.data() + c * n;
        // Clipped, or mostly black in a channel: no reliable value.
        if (p[6] > 0 || !(p[3] > 0.05f && p[4] > 0.05f && p[5] > 0.05f)) continue;
        const double x = (double(p[0]) + p[1] + p[2]) / 3;  // relative exposure
        if (x > 0) v.log_lum[c] = float(std::log(x / t));
    }
    const int stride = std::max(1, k.width / grid_width);
    for (int pv = stride / 2; pv < k.height; pv += stride)
        for (int pu = stride / 2; pu < k.width; pu += stride) {
            const double value = read_cells(v, HdrAccumulator::grid_coordinate(pu, v.s), HdrAccumulator::grid_coordinate(pv, v.s));
            if (!std::isfinite(value)) continue;
            v.rays.push_back(pixel_ray(k, pu, pv));
            v.values.push_back(float(value));
        }
    return v;
}

std::optional<PairMeasurement> align_pair(const AlignmentView& a, const glm::dquat& ra, const AlignmentView& b,
                                          const glm::dquat& rb, const PairSettings& settings) {
    if (int(a.rays.size()) < settings.min_points) return std::nullopt;
    const glm::dquat b_from_world = glm::conjugate(rb);
    const Intrinsics& kb = b.intrinsics;
    const auto residuals = [&](const glm::dvec3& delta, std::vector<double>& r) {
        const glm::dquat b_from_a = b_from_world * rotation_from_vector(delta) * ra;
        r.assign(a.rays.size(), std::nan(""));
        for (std::size_t i = 0; i < a.rays.size(); ++i) {
            const auto px = project(kb, b_from_a * a.rays[i]);
            if (!px) continue;
            const double value =
                read_cells(b, HdrAccumulator::grid_coordinate(px->u, b.s), HdrAccumulator::grid_coordinate(px->v, b.s));
            if (std::isfinite(value)) r[i] = double(a.values[i]) - value;
        }
    };
    RotationFitSettings fs;
    fs.min_points = settings.min_points;
    const RotationFit fit = fit_rotation(residuals, fs);
    if (!fit.estimated || fit.points < settings.min_points || !(fit.cost_after <= fit.cost_before)) return std::nullopt;
    const double sigma = deg(fit.sigma_rad);
    if (sigma > settings.max_sigma_deg || deg(glm::length(fit.delta)) > settings.max_angle_deg) return std::nullopt;
    PairMeasurement m;
    m.relative = unit_rotation(rotation_from_vector(fit.delta) * ra * glm::conjugate(rb));
    // The information, scaled so that no pair claims better than min_sigma_deg: neighbouring
    // samples are not independent, and the fit's own figure is far too confident.
    const double floor_info = 1.0 / std::pow(settings.min_sigma_deg * kPi / 180.0, 2);
    double scale = 1.0;
    for (int p = 0; p < 3; ++p) scale = std::max(scale, fit.information[p][p] / floor_info);
    m.information = fit.information / scale;
    m.sigma_deg = std::max(sigma, settings.min_sigma_deg);
    m.points = fit.points;
    return m;
}

AdjustmentResult adjust_orientations(const std::vector<double>& t_s, const std::vector<glm::dquat>& sensor,
                                     const std::vector<glm::dquat>& initial, const std::vector<PairMeasurement>& pairs,
                                     const AdjustmentSettings& settings) {
    const int n = int(initial.size());
    if (int(t_s.size()) != n || int(sensor.size()) != n) throw InputError("adjust_orientations: inputs of different lengths");
    AdjustmentResult out;
    out.orientations = initial;
    if (n == 0) return out;
    const int unknowns = 3 * n + 3;  // a rotation vector per frame, then the drift rate
    std::vector<glm::dquat>& R = out.orientations;
    glm::dvec3 b(0);
    const double w_sensor = 1.0 / std::pow(settings.sensor_sigma_deg * kPi / 180.0, 2);
    std::vector<double> pair_weight(pairs.size(), 1.0);  // Huber reweighting of the pairs
    for (int it = 0; it < settings.iterations; ++it) {
        cv::Mat H = cv::Mat::zeros(unknowns, unknowns, CV_64F), g = cv::Mat::zeros(unknowns, 1, CV_64F);
        // Adds the 3x3 block m (GLM: m[column][row]) at H's rows i3.., columns j3...
        const auto add_block = [&](int i3, int j3, const glm::dmat3& m) {
            for (int p = 0; p < 3; ++p)
                for (int q = 0; q < 3; ++q) H.at<double>(i3 + p, j3 + q) += m[q][p];
        };
        // A constraint on the relative rotation of frames i and j: e ~ e0 + x_i - Q0 x_j.
        const auto add_relative = [&](int i, int j, const glm::dvec3& e0, const glm::dmat3& L) {
            const glm::dmat3 Q0 = glm::mat3_cast(unit_rotation(R[std::size_t(i)] * glm::conjugate(R[std::size_t(j)])));
            // J_i = I, J_j = -Q0. H += J^T L J, g += J^T L e0.
            const glm::dmat3 LQ = L * Q0, QtL = glm::transpose(Q0) * L, QtLQ = glm::transpose(Q0) * LQ;
            add_block(3 * i, 3 * i, L);
            add_block(3 * i, 3 * j, -LQ);
            add_block(3 * j, 3 * i, -QtL);
            add_block(3 * j, 3 * j, QtLQ);
            const glm::dvec3 le = L * e0, qle = QtL * e0;
            for (int p = 0; p < 3; ++p) {
                g.at<double>(3 * i + p) += le[p];
                g.at<double>(3 * j + p) -= qle[p];
            }
        };
        double pair_ss = 0;
        for (std::size_t k = 0; k < pairs.size(); ++k) {
            const PairMeasurement& m = pairs[k];
            const glm::dvec3 e0 = rotation_vector(
                R[std::size_t(m.i)] * glm::conjugate(R[std::size_t(m.j)]) * glm::conjugate(m.relative));
            // Mahalanobis length of the error: beyond 3 the pair counts less (a false match).
            const double maha = std::sqrt(glm::dot(e0, m.information * e0));
            pair_weight[k] = it == 0 || maha <= 3 ? 1.0 : 3 / maha;
            pair_ss += glm::dot(e0, e0);
            add_relative(m.i, m.j, e0, pair_weight[k] * m.information);
        }
        out.pair_rms_deg = pairs.empty() ? 0 : deg(std::sqrt(pair_ss / double(pairs.size())));
        // The sensor's relative rotation between frames close in time.
        for (int i = 1; i < n; ++i) {
            const double dt = std::abs(t_s[std::size_t(i)] - t_s[std::size_t(i - 1)]);
            if (dt > settings.relative_max_dt_s) continue;
            const double sigma = (settings.relative_sigma_deg + settings.relative_sigma_deg_per_s * dt) * kPi / 180.0;
            const glm::dquat s_rel = unit_rotation(sensor[std::size_t(i)] * glm::conjugate(sensor[std::size_t(i - 1)]));
            const glm::dvec3 e0 =
                rotation_vector(R[std::size_t(i)] * glm::conjugate(R[std::size_t(i - 1)]) * glm::conjugate(s_rel));
            add_relative(i, i - 1, e0, glm::dmat3(1.0 / (sigma * sigma)));
        }
        // The sensor's absolute orientation with the drift line: e = log(R_f S_f^-1) - b t_f.
        double sensor_ss = 0;
        for (int f = 0; f < n; ++f) {
            const double t = t_s[std::size_t(f)];
            const glm::dvec3 e0 = rotation_vector(R[std::size_t(f)] * glm::conjugate(sensor[std::size_t(f)])) - b * t;
            sensor_ss += glm::dot(e0, e0);
            for (int p = 0; p < 3; ++p) {
                // J = [I at x_f, -t I at b].
                H.at<double>(3 * f + p, 3 * f + p) += w_sensor;
                H.at<double>(3 * f + p, 3 * n + p) -= w_sensor * t;
                H.at<double>(3 * n + p, 3 * f + p) -= w_sensor * t;
                H.at<double>(3 * n + p, 3 * n + p) += w_sensor * t * t;
                g.at<double>(3 * f + p) += w_sensor * e0[p];
                g.at<double>(3 * n + p) -= w_sensor * t * e0[p];
            }
        }
        out.sensor_rms_deg = deg(std::sqrt(sensor_ss / n));
        for (int p = 0; p < 3; ++p) H.at<double>(3 * n + p, 3 * n + p) += 1e-9;  // a session shorter than an instant
        cv::Mat step;
        if (!cv::solve(H, -g, step, cv::DECOMP_CHOLESKY)) throw RuntimeError("global adjustment: singular system");
        double largest = 0;
        for (int f = 0; f < n; ++f) {
            const glm::dvec3 x(step.at<double>(3 * f), step.at<double>(3 * f + 1), step.at<double>(3 * f + 2));
            R[std::size_t(f)] = unit_rotation(rotation_from_vector(x) * R[std::size_t(f)]);
            largest = std::max(largest, glm::length(x));
        }
        b += glm::dvec3(step.at<double>(3 * n), step.at<double>(3 * n + 1), step.at<double>(3 * n + 2));
        if (largest < 1e-7) break;
    }
    out.drift_rate_rad_per_s = b;
    out.pairs_used = int(pairs.size());
    return out;
}

ScanAdjustment adjust_scan(const std::vector<AlignmentView>& views, const std::vector<double>& t_s,
                           const std::vector<glm::dquat>& sensor, std::vector<glm::dquat> initial, int rounds,
                           int threads,
                           const std::function<void()>& round_done, const PairSettings& pair_settings,
                           const AdjustmentSettings& settings) {
    auto clock = std::chrono::steady_clock::now();
    const auto lap = [&] {
        const auto now = std::chrono::steady_clock::now();
        const double s = std::chrono::duration<double>(now - clock).count();
        clock = now;
        return s;
    };
    char text[96];
    const std::size_t n = views.size();
    if (t_s.size() != n || sensor.size() != n || initial.size() != n)
        throw InputError("adjust_scan: inputs of different lengths");
    const auto usable = [&](std::size_t i) { return int(views[i].rays.size()) >= pair_settings.min_points; };
    const auto axis = [](const glm::dquat& q) { return q * glm::dvec3(0, 0, -1); };
    std::vector<std::pair<int, int>> candidates;
    for (std::size_t i = 0; i < n; ++i) {
        if (!usable(i)) continue;
        const Intrinsics& k = views[i].intrinsics;
        const double half_fov = std::atan2(0.5 * k.width, k.fx);
        const glm::dvec3 ai = axis(initial[i]);
        int near = 0;
        std::vector<std::pair<double, int>> far;
        for (std::size_t j = i; j-- > 0;) {
            if (!usable(j)) continue;
            const double angle = std::acos(std::clamp(glm::dot(ai, axis(initial[j])), -1.0, 1.0));
            if (angle > half_fov) continue;
            if (t_s[i] - t_s[j] >= 3.0) far.push_back({angle, int(j)});
            else if (near < 2) {
                candidates.push_back({int(i), int(j)});
                ++near;
            }
        }
        std::sort(far.begin(), far.end());
        for (std::size_t k2 = 0; k2 < std::min<std::size_t>(4, far.size()); ++k2)
            candidates.push_back({int(i), far[k2].second});
    }
    ScanAdjustment out;
    out.pairs_tried = int(candidates.size());
    std::snprintf(text, sizeof text, "select %.3f", lap());
    out.profile = text;
    out.result.orientations = initial;
    for (int round = 0; round < rounds; ++round) {
        std::vector<std::optional<PairMeasurement>> measured(candidates.size());
        const std::vector<glm::dquat>& q = out.result.orientations;
        parallel_for(int(candidates.size()), threads, [&](int c) {
            const auto [i, j] = candidates[std::size_t(c)];
            auto& m = measured[std::size_t(c)];
            m = align_pair(views[std::size_t(i)], q[std::size_t(i)], views[std::size_t(j)], q[std::size_t(j)],
                           pair_settings);
            if (m) {
                m->i = i;
                m->j = j;
            }
        });
        std::vector<PairMeasurement> pairs;
        for (const auto& m : measured)
            if (m) pairs.push_back(*m);
        const double align_s = lap();
        out.result = adjust_orientations(t_s, sensor, out.result.orientations, pairs, settings);
        std::snprintf(text, sizeof text, ", round %d align %.3f solve %.3f", round + 1, align_s, lap());
        out.profile += text;
        if (round_done) round_done();
    }
    return out;
}

}  // namespace glint::capture
