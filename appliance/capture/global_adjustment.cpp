#include "appliance/capture/global_adjustment.hpp"

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cmath>
#include <functional>
#include <Eigen/SparseCholesky>
#include <Eigen/SparseCore>

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

// Gaussian blur of a w x h grid by sigma (in cells), separable, out to 1.5 sigma. A cell with an
// invalid (NaN) cell anywhere in its window, or whose window leaves the grid, is invalid: beside a
// clipped or black region a mean over what is there would lean towards the side that is there, and
// a frame at another exposure clips elsewhere. (Keeping such cells unsmoothed instead mixed raw
// and smoothed reads of the same place in two frames: the stress room's pairs aligned from the
// truth came out 0.118 degrees off in the median, as without smoothing.)
void blur_cells(std::vector<float>& g, int w, int h, double sigma) {
    if (!(sigma > 0)) return;
    const int r = std::max(1, int(std::ceil(1.5 * sigma)));
    std::vector<double> k(std::size_t(2 * r + 1));
    double sum = 0;
    for (int d = -r; d <= r; ++d) sum += k[std::size_t(d + r)] = std::exp(-0.5 * d * d / (sigma * sigma));
    for (double& x : k) x /= sum;
    const auto pass = [&](const std::vector<float>& in, std::vector<float>& out, int step, int along, int across) {
        // along: cells in the blurred direction, `step` apart in memory; across: lines of them.
        out.assign(in.size(), std::nanf(""));
        for (int a = 0; a < across; ++a) {
            const std::size_t base = step == 1 ? std::size_t(a) * std::size_t(w) : std::size_t(a);
            for (int i = r; i + r < along; ++i) {
                double v = 0;
                bool ok = true;
                for (int d = -r; ok && d <= r; ++d) {
                    const float x = in[base + std::size_t(i + d) * std::size_t(step)];
                    if (std::isnan(x)) ok = false;
                    else v += k[std::size_t(d + r)] * x;
                }
                if (ok) out[base + std::size_t(i) * std::size_t(step)] = float(v);
            }
        }
    };
    std::vector<float> across;
    pass(g, across, 1, w, h);
    pass(across, g, w, h, w);
}

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
    // The cells are smoothed to the grid's spacing (a Gaussian of half the grid stride, the usual
    // prefilter for sampling at that stride) before the grid reads them, in this frame and in the
    // frame it is aligned against. Unsmoothed, each read was one 2x2-pixel cell's noise: where the
    // scene is smooth (a dim room's gradients) that noise was most of the texture, so the fit
    // settled in the noise's minima near its start (a cell is 0.44 degrees) and its gradients
    // made it claim 0.01-0.02 degrees. Aligned from the true orientations, the pairs it trusted
    // most were a median 0.12 degrees off on the stress rooms, 0.035 smoothed (courtyard: 0.027,
    // 0.014); from the sensor's, they kept 110 % of their starting error, 57 % smoothed.
    blur_cells(v.log_lum, v.cells_w, v.cells_h, 0.5 * stride / v.s);
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
    m.relative = unit_rotation(b_from_world * rotation_from_vector(fit.delta) * ra);
    // The information, scaled so that no pair claims better than min_sigma_deg: neighbouring
    // samples are not independent, and the fit's own figure is far too confident.
    const double floor_info = 1.0 / std::pow(settings.min_sigma_deg * kPi / 180.0, 2);
    double scale = 1.0;
    for (int p = 0; p < 3; ++p) scale = std::max(scale, fit.information[p][p] / floor_info);
    // The fit's delta is a world-frame rotation at rb; the error is kept in camera b's frame.
    const glm::dmat3 rb_m = glm::mat3_cast(rb);
    m.information = glm::transpose(rb_m) * (fit.information / scale) * rb_m;
    m.sigma_deg = std::max(sigma, settings.min_sigma_deg);
    m.points = fit.points;
    return m;
}

AdjustmentResult adjust_orientations(const std::vector<double>& t_s, const std::vector<glm::dquat>& sensor,
                                     const std::vector<glm::dquat>& initial, const std::vector<PairMeasurement>& pairs,
                                     const AdjustmentSettings& settings, const std::vector<glm::dvec3>& camera_rates) {
    const int n = int(initial.size());
    if (int(t_s.size()) != n || int(sensor.size()) != n) throw InputError("adjust_orientations: inputs of different lengths");
    if (!camera_rates.empty() && int(camera_rates.size()) != n)
        throw InputError("adjust_orientations: camera rates for " + std::to_string(camera_rates.size()) + " of " +
                         std::to_string(n) + " frames");
    AdjustmentResult out;
    out.orientations = initial;
    if (n == 0) return out;
    // The drift rate b = sum_k beta_k u_k over its axes u_k: the vertical alone, or all three.
    std::vector<glm::dvec3> drift_axes;
    if (settings.drift_heading_only)
        drift_axes = {glm::dvec3(0, 1, 0)};
    else
        drift_axes = {glm::dvec3(1, 0, 0), glm::dvec3(0, 1, 0), glm::dvec3(0, 0, 1)};
    const int axes = int(drift_axes.size());
    // The calibration's refinement: the mounting's rotation (3) and, with the rates, the time
    // offset (1), after the drift rate.
    const bool refine = settings.refine_calibration;
    const bool refine_time = refine && !camera_rates.empty();
    const int mount0 = 3 * n + axes, time0 = mount0 + (refine ? 3 : 0);
    const int unknowns = time0 + (refine_time ? 1 : 0);  // a rotation vector per frame, the drift rate, then these
    std::vector<glm::dquat>& R = out.orientations;
    glm::dvec3 b(0);
    glm::dvec3 delta(0);  // the mounting's refinement, camera frame, rad
    double tau = 0;       // the time offset's, s
    const double w_mount = 1.0 / std::pow(settings.mounting_prior_deg * kPi / 180.0, 2);
    const double w_time = 1.0 / std::pow(settings.time_offset_prior_ms * 1e-3, 2);
    // Frame f's camera rate (0 without the time offset's refinement), its refinement u_f =
    // delta + w_f tau (camera frame) and the sensor's orientation it corrects: S_f exp(u_f).
    const auto rate_of = [&](int f) { return refine_time ? camera_rates[std::size_t(f)] : glm::dvec3(0); };
    const auto refinement_of = [&](int f) { return delta + rate_of(f) * tau; };
    const auto corrected_sensor = [&](int f) {
        return refine ? unit_rotation(sensor[std::size_t(f)] * rotation_from_vector(refinement_of(f)))
                      : sensor[std::size_t(f)];
    };
    const double w_sensor = 1.0 / std::pow(settings.sensor_sigma_deg * kPi / 180.0, 2);
    std::vector<double> pair_weight(pairs.size(), 1.0);  // Huber reweighting of the pairs
    // The normal equations are block-sparse: a 3x3 block per frame, per pair and per close frame
    // pair, and the drift rate's rows and columns (one per axis) against every frame. A sparse Cholesky
    // (LDL^T, fill-reducing ordering) solves them in about linear time where a dense one grows
    // with the cube of the frame count.
    std::vector<Eigen::Triplet<double>> triplets;
    triplets.reserve(pairs.size() * 36 + std::size_t(n) * 72 + 64);
    Eigen::VectorXd g(unknowns);
    Eigen::SparseMatrix<double> H(unknowns, unknowns);
    Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>> solver;
    bool analysed = false;
    for (int it = 0; it < settings.iterations; ++it) {
        triplets.clear();
        g.setZero();
        // Adds the 3x3 block m (GLM: m[column][row]) at H's rows i3.., columns j3...
        const auto add_block = [&](int i3, int j3, const glm::dmat3& m) {
            for (int p = 0; p < 3; ++p)
                for (int q = 0; q < 3; ++q) triplets.emplace_back(i3 + p, j3 + q, m[q][p]);
        };
        // A constraint on the relative rotation of frames i and j, measured as C = R_j^-1 R_i with
        // information Lc in camera j's frame: e = log(R_i C^-1 R_j^-1) (world frame), and under
        // left perturbations e ~ e0 + x_i - E0 x_j with E0 = R_i C^-1 R_j^-1 (near the identity).
        // Returns |e0|^2.
        const auto add_relative = [&](int i, int j, const glm::dquat& C, const glm::dmat3& Lc, double weight) {
            const glm::dquat E0 = unit_rotation(R[std::size_t(i)] * glm::conjugate(C) * glm::conjugate(R[std::size_t(j)]));
            const glm::dvec3 e0 = rotation_vector(E0);
            const glm::dmat3 Rj = glm::mat3_cast(R[std::size_t(j)]);
            const glm::dmat3 L = weight * (Rj * Lc * glm::transpose(Rj));
            const glm::dmat3 Q0 = glm::mat3_cast(E0);
            // J_i = I, J_j = -Q0. H += J^T L J, g += J^T L e0.
            const glm::dmat3 LQ = L * Q0, QtL = glm::transpose(Q0) * L, QtLQ = glm::transpose(Q0) * LQ;
            add_block(3 * i, 3 * i, L);
            add_block(3 * i, 3 * j, -LQ);
            add_block(3 * j, 3 * i, -QtL);
            add_block(3 * j, 3 * j, QtLQ);
            const glm::dvec3 le = L * e0, qle = QtL * e0;
            for (int p = 0; p < 3; ++p) {
                g[3 * i + p] += le[p];
                g[3 * j + p] -= qle[p];
            }
            return e0;
        };
        double pair_ss = 0;
        for (std::size_t k = 0; k < pairs.size(); ++k) {
            const PairMeasurement& m = pairs[k];
            const glm::dquat E0 = R[std::size_t(m.i)] * glm::conjugate(m.relative) * glm::conjugate(R[std::size_t(m.j)]);
            const glm::dvec3 e0 = rotation_vector(E0);
            // Mahalanobis length of the error: beyond 3 the pair counts less (a false match).
            const glm::dvec3 ec = glm::conjugate(R[std::size_t(m.j)]) * e0;  // in camera j's frame
            const double maha = std::sqrt(std::max(0.0, glm::dot(ec, m.information * ec)));
            const double kr = settings.pair_robust_k;
            pair_weight[k] = (it == 0 && !settings.robust_from_start) ? 1.0
                             : settings.pair_cauchy           ? 1.0 / (1.0 + (maha / kr) * (maha / kr))
                             : maha <= kr                     ? 1.0
                                                              : kr / maha;
            pair_ss += glm::dot(e0, e0);
            add_relative(m.i, m.j, m.relative, m.information, pair_weight[k]);
        }
        out.pair_rms_deg = pairs.empty() ? 0 : deg(std::sqrt(pair_ss / double(pairs.size())));
        // The sensor's relative rotation (in the camera's frame: what the gyros measure) between
        // frames close in time. With the calibration refined, between the sensor's orientations
        // as the current refinement corrects them (held for this step: the mounting turns a
        // relative rotation's axis, which a stale one tilts against the images' by its error).
        for (int i = 1; i < n; ++i) {
            const double dt = std::abs(t_s[std::size_t(i)] - t_s[std::size_t(i - 1)]);
            if (dt > settings.relative_max_dt_s) continue;
            const double sigma = (settings.relative_sigma_deg + settings.relative_sigma_deg_per_s * dt) * kPi / 180.0;
            const glm::dquat s_rel = unit_rotation(glm::conjugate(corrected_sensor(i - 1)) * corrected_sensor(i));
            add_relative(i, i - 1, s_rel, glm::dmat3(1.0 / (sigma * sigma)), 1.0);
        }
        // The sensor's absolute orientation with the drift line and the calibration's refinement:
        // e = log(R_f exp(-u_f) S_f^-1) - b t_f, u_f = delta + w_f tau (camera frame). With
        // R_f exp(-u) = exp(-A_f u) R_f (A_f = R_f's matrix, camera to world), J = [I at x_f,
        // -t u_k at beta_k (the axes u_k are orthonormal), -A_f at delta, -A_f w_f at tau].
        double sensor_ss = 0;
        double hbb = 0;  // sum of w t^2: each axis's diagonal
        double gb[3] = {0, 0, 0};
        glm::dmat3 h_mb(0);         // delta against beta_k: column k
        glm::dvec3 h_tb(0);         // tau against beta_k
        glm::dvec3 h_mt(0);         // delta against tau
        double h_tt = 0;            // tau against itself
        glm::dvec3 g_m(0);
        double g_t = 0;
        for (int f = 0; f < n; ++f) {
            const double t = t_s[std::size_t(f)];
            const glm::dvec3 rate = rate_of(f);
            const glm::dvec3 e0 = rotation_vector(R[std::size_t(f)] * glm::conjugate(corrected_sensor(f))) - b * t;
            sensor_ss += glm::dot(e0, e0);
            for (int p = 0; p < 3; ++p) {
                triplets.emplace_back(3 * f + p, 3 * f + p, w_sensor);
                g[3 * f + p] += w_sensor * e0[p];
            }
            for (int k = 0; k < axes; ++k) {
                const glm::dvec3& u = drift_axes[std::size_t(k)];
                for (int p = 0; p < 3; ++p) {
                    if (u[p] == 0) continue;
                    triplets.emplace_back(3 * f + p, 3 * n + k, -w_sensor * t * u[p]);
                    triplets.emplace_back(3 * n + k, 3 * f + p, -w_sensor * t * u[p]);
                }
                gb[k] -= w_sensor * t * glm::dot(u, e0);
            }
            hbb += w_sensor * t * t;
            if (!refine) continue;
            const glm::dmat3 A = glm::mat3_cast(R[std::size_t(f)]);
            const glm::dmat3 At = glm::transpose(A);
            // x_f against delta: -w A (and its transpose); delta's own block sums w A^T A = w I.
            add_block(3 * f, mount0, -w_sensor * A);
            add_block(mount0, 3 * f, -w_sensor * At);
            const glm::dvec3 Ate = At * e0;
            g_m -= w_sensor * Ate;
            for (int k = 0; k < axes; ++k) h_mb[k] += w_sensor * t * (At * drift_axes[std::size_t(k)]);
            if (refine_time) {
                const glm::dvec3 a_w = A * rate;  // the rate in the world frame
                for (int p = 0; p < 3; ++p) {
                    triplets.emplace_back(3 * f + p, time0, -w_sensor * a_w[p]);
                    triplets.emplace_back(time0, 3 * f + p, -w_sensor * a_w[p]);
                }
                h_mt += w_sensor * rate;  // A^T A w = w
                h_tt += w_sensor * glm::dot(rate, rate);
                g_t -= w_sensor * glm::dot(a_w, e0);
                for (int k = 0; k < axes; ++k) h_tb[k] += w_sensor * t * glm::dot(a_w, drift_axes[std::size_t(k)]);
            }
        }
        for (int k = 0; k < axes; ++k) {
            triplets.emplace_back(3 * n + k, 3 * n + k, hbb + 1e-9);  // a session shorter than an instant
            g[3 * n + k] += gb[k];
        }
        if (refine) {
            // Their own blocks, the priors about the calibration (delta = 0, tau = 0), and their
            // products with the drift rate.
            add_block(mount0, mount0, glm::dmat3(w_sensor * n + w_mount));
            for (int p = 0; p < 3; ++p) {
                g[mount0 + p] += g_m[p] + w_mount * delta[p];
                for (int k = 0; k < axes; ++k) {
                    triplets.emplace_back(mount0 + p, 3 * n + k, h_mb[k][p]);
                    triplets.emplace_back(3 * n + k, mount0 + p, h_mb[k][p]);
                }
            }
            if (refine_time) {
                triplets.emplace_back(time0, time0, h_tt + w_time);
                g[time0] += g_t + w_time * tau;
                for (int p = 0; p < 3; ++p) {
                    triplets.emplace_back(mount0 + p, time0, h_mt[p]);
                    triplets.emplace_back(time0, mount0 + p, h_mt[p]);
                }
                for (int k = 0; k < axes; ++k) {
                    triplets.emplace_back(time0, 3 * n + k, h_tb[k]);
                    triplets.emplace_back(3 * n + k, time0, h_tb[k]);
                }
            }
        }
        out.sensor_rms_deg = deg(std::sqrt(sensor_ss / n));
        H.setFromTriplets(triplets.begin(), triplets.end());  // duplicates are summed
        if (!analysed) {
            solver.analyzePattern(H);  // the pattern is the same every iteration
            analysed = true;
        }
        solver.factorize(H);
        if (solver.info() != Eigen::Success) throw RuntimeError("global adjustment: singular system");
        const Eigen::VectorXd step = solver.solve(-g);
        double largest = 0;
        for (int f = 0; f < n; ++f) {
            const glm::dvec3 x(step[3 * f], step[3 * f + 1], step[3 * f + 2]);
            R[std::size_t(f)] = unit_rotation(rotation_from_vector(x) * R[std::size_t(f)]);
            largest = std::max(largest, glm::length(x));
        }
        for (int k = 0; k < axes; ++k) b += step[3 * n + k] * drift_axes[std::size_t(k)];
        if (refine) {
            const glm::dvec3 d_delta(step[mount0], step[mount0 + 1], step[mount0 + 2]);
            delta += d_delta;
            largest = std::max(largest, glm::length(d_delta));
        }
        if (refine_time) {
            tau += step[time0];
            largest = std::max(largest, std::abs(step[time0]));  // the same 1e-7, in seconds
        }
        if (largest < 1e-7) break;
    }
    out.drift_rate_rad_per_s = b;
    out.mounting_rad = delta;
    out.time_offset_s = tau;
    if (refine) {
        double ss = 0;
        for (int f = 0; f < n; ++f) ss += glm::dot(refinement_of(f), refinement_of(f));
        out.calibration_turn_deg = deg(std::sqrt(ss / n));
    }
    out.pairs_used = int(pairs.size());
    return out;
}

std::vector<std::pair<int, int>> candidate_pairs_of_frame(const std::vector<AlignmentView>& views,
                                                          const std::vector<double>& t_s,
                                                          const std::vector<glm::dquat>& orientations, int i,
                                                          const PairSettings& pair_settings) {
    std::vector<std::pair<int, int>> out;
    const auto usable = [&](std::size_t k) { return int(views[k].rays.size()) >= pair_settings.min_points; };
    const auto axis = [](const glm::dquat& q) { return q * glm::dvec3(0, 0, -1); };
    const std::size_t fi = std::size_t(i);
    if (!usable(fi)) return out;
    const Intrinsics& k = views[fi].intrinsics;
    const double half_fov = std::atan2(0.5 * k.width, k.fx);
    const glm::dvec3 ai = axis(orientations[fi]);
    int near = 0;
    std::vector<std::pair<double, int>> far;
    for (std::size_t j = fi; j-- > 0;) {
        if (!usable(j)) continue;
        const double angle = std::acos(std::clamp(glm::dot(ai, axis(orientations[j])), -1.0, 1.0));
        if (angle > half_fov) continue;
        if (t_s[fi] - t_s[j] >= 3.0) far.push_back({angle, int(j)});
        else if (near < 2) {
            out.push_back({i, int(j)});
            ++near;
        }
    }
    std::sort(far.begin(), far.end());
    for (std::size_t k2 = 0; k2 < std::min<std::size_t>(4, far.size()); ++k2) out.push_back({i, far[k2].second});
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
    std::vector<std::pair<int, int>> candidates;
    for (std::size_t i = 0; i < n; ++i) {
        const auto c = candidate_pairs_of_frame(views, t_s, initial, int(i), pair_settings);
        candidates.insert(candidates.end(), c.begin(), c.end());
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

OnlineAdjustment::OnlineAdjustment(int threads, const PairSettings& pair_settings, const AdjustmentSettings& settings)
    : threads_(std::max(1, threads)), pair_settings_(pair_settings), settings_(settings) {
    // Every solve starts from the last solution, so the pairs are weighed from the first step;
    // Cauchy with k = 2 rather than Huber beyond 3: a pair 8 of its standard deviations off is a
    // median 0.22 degrees wrong against the truth (sunset), one within 2 a median 0.02.
    settings_.robust_from_start = true;
    settings_.pair_cauchy = true;
    settings_.pair_robust_k = 2;
    // The sensor's error changes by 0.08 degrees RMS (3 axes) between frames 0.33 s apart on the
    // benchmark sessions: 0.02 + 0.15 degrees per second apart per axis, not 0.3, lets fewer
    // frames be pulled off their neighbours by a bad pair.
    settings_.relative_sigma_deg_per_s = 0.15;
}

double OnlineAdjustment::change_deg(const Pair& p) const {
    const glm::dquat now = glm::conjugate(q_[std::size_t(p.j)]) * q_[std::size_t(p.i)];
    return deg(angle_between(now, p.start));
}

double OnlineAdjustment::largest_pair_change_deg() const {
    double worst = 0;
    for (const Pair& p : pairs_) worst = std::max(worst, change_deg(p));
    return worst;
}

void OnlineAdjustment::align(const std::vector<std::size_t>& which) {
    if (which.empty()) return;
    parallel_for(int(which.size()), std::min<int>(threads_, int(which.size())), [&](int c) {
        Pair& p = pairs_[which[std::size_t(c)]];
        const glm::dquat& qi = q_[std::size_t(p.i)];
        const glm::dquat& qj = q_[std::size_t(p.j)];
        p.start = unit_rotation(glm::conjugate(qj) * qi);
        p.measured = align_pair(views_[std::size_t(p.i)], qi, views_[std::size_t(p.j)], qj, pair_settings_);
        if (p.measured) {
            p.measured->i = p.i;
            p.measured->j = p.j;
        }
    });
    alignments_ += (long long)which.size();
}

void OnlineAdjustment::add_frame(AlignmentView view, double t_s, const glm::dquat& sensor, const glm::dquat& live,
                                 const glm::dvec3& camera_rate) {
    const int f = frames();
    views_.push_back(std::move(view));
    t_s_.push_back(t_s);
    sensor_.push_back(sensor);
    rates_.push_back(camera_rate);
    live_.push_back(live);
    // Started where the last frame's correction of its sensor orientation carries it: the
    // sensor's short-term motion is smooth, the live pass's per-frame corrections are not (a
    // start from them took sunset's error after 60 s from 0.25 to 0.44 degrees).
    q_.push_back(f == 0 ? live : unit_rotation(q_.back() * glm::conjugate(sensor_[std::size_t(f - 1)]) * sensor));
    result_.orientations = q_;
    std::vector<std::size_t> fresh;
    for (const auto& [i, j] : candidate_pairs_of_frame(views_, t_s_, live_, f, pair_settings_)) {
        fresh.push_back(pairs_.size());
        pairs_.push_back({i, j, {}, std::nullopt});
    }
    align(fresh);
}

int OnlineAdjustment::realign(int max_pairs, double min_change_deg) {
    std::vector<std::pair<double, std::size_t>> moved;
    for (std::size_t k = 0; k < pairs_.size(); ++k) {
        const double c = change_deg(pairs_[k]);
        if (c > min_change_deg) moved.push_back({c, k});
    }
    if (max_pairs >= 0 && int(moved.size()) > max_pairs) {
        std::partial_sort(moved.begin(), moved.begin() + max_pairs, moved.end(), std::greater<>());
        moved.resize(std::size_t(max_pairs));
    }
    std::vector<std::size_t> which;
    for (const auto& m : moved) which.push_back(m.second);
    align(which);
    return int(which.size());
}

std::vector<PairMeasurement> OnlineAdjustment::measured_pairs() const {
    std::vector<PairMeasurement> pairs;
    for (const Pair& p : pairs_)
        if (p.measured) pairs.push_back(*p.measured);
    return pairs;
}

AdjustmentResult OnlineAdjustment::refined_solution() const {
    AdjustmentSettings refined = settings_;
    refined.refine_calibration = true;
    return adjust_orientations(t_s_, sensor_, q_, measured_pairs(), refined, rates_);
}

void OnlineAdjustment::adopt(const AdjustmentResult& result) {
    if (result.orientations.size() != q_.size())
        throw RuntimeError("internal: an adjustment of " + std::to_string(result.orientations.size()) + " frames for " +
                           std::to_string(q_.size()));
    result_ = result;
    q_ = result_.orientations;
}

void OnlineAdjustment::solve() {
    const std::vector<PairMeasurement> pairs = measured_pairs();
    result_ = adjust_orientations(t_s_, sensor_, q_, pairs, settings_, rates_);
    q_ = result_.orientations;
}

}  // namespace glint::capture
