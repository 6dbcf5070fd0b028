#include "appliance/capture/orientation_refinement.hpp"

#include <algorithm>
#include <cmath>

#include "appliance/capture/drift_correction.hpp"
#include "appliance/core/equirect.hpp"

namespace glint::capture {

namespace {

// Weighted least squares of y = a + b t (per axis, same weights); b = 0 when `fit_rate` is off.
void fit_line(const std::vector<double>& t, const std::vector<firmware::Vec3d>& y, const std::vector<double>& w,
              bool fit_rate, firmware::Vec3d& a, firmware::Vec3d& b) {
    double sw = 0, st = 0, stt = 0;
    firmware::Vec3d sy{}, sty{};
    for (std::size_t i = 0; i < t.size(); ++i) {
        sw += w[i];
        st += w[i] * t[i];
        stt += w[i] * t[i] * t[i];
        sy = {sy.x + w[i] * y[i].x, sy.y + w[i] * y[i].y, sy.z + w[i] * y[i].z};
        sty = {sty.x + w[i] * t[i] * y[i].x, sty.y + w[i] * t[i] * y[i].y, sty.z + w[i] * t[i] * y[i].z};
    }
    const double det = sw * stt - st * st;
    if (!fit_rate || !(det > 1e-12 * sw * sw)) {
        a = {sy.x / sw, sy.y / sw, sy.z / sw};
        b = {};
        return;
    }
    b = {(sw * sty.x - st * sy.x) / det, (sw * sty.y - st * sy.y) / det, (sw * sty.z - st * sy.z) / det};
    a = {(sy.x - b.x * st) / sw, (sy.y - b.y * st) / sw, (sy.z - b.z * st) / sw};
}

firmware::Vec3d minus(const firmware::Vec3d& p, const firmware::Vec3d& q) { return {p.x - q.x, p.y - q.y, p.z - q.z}; }
double norm(const firmware::Vec3d& v) { return std::sqrt(v.x * v.x + v.y * v.y + v.z * v.z); }

}  // namespace

std::vector<Quatd> anchor_to_sensor(const std::vector<RefinedFrame>& frames, DriftLine* line, AnchorSettings settings) {
    std::vector<double> t;
    std::vector<firmware::Vec3d> r;
    for (const RefinedFrame& f : frames)
        if (f.trusted) {
            t.push_back(f.t_s);
            r.push_back(rotation_vector_of(firmware::normalized(f.image * f.sensor.conj())));
        }
    std::vector<Quatd> out;
    out.reserve(frames.size());
    if (line) *line = {};
    if (int(t.size()) < settings.min_trusted) {
        for (const RefinedFrame& f : frames) out.push_back(f.trusted ? f.image : f.sensor);
        return out;
    }
    const bool fit_rate = t.back() - t.front() >= settings.min_span_s;
    // Huber reweighting: a frame whose alignment went wrong (or whose sensor sample was an
    // outlier) counts less, so the line follows the drift, not the worst frame.
    std::vector<double> w(t.size(), 1.0);
    firmware::Vec3d a{}, b{};
    for (int it = 0; it < 5; ++it) {
        fit_line(t, r, w, fit_rate, a, b);
        std::vector<double> res(t.size());
        for (std::size_t i = 0; i < t.size(); ++i)
            res[i] = norm(minus(r[i], {a.x + b.x * t[i], a.y + b.y * t[i], a.z + b.z * t[i]}));
        std::vector<double> sorted = res;
        std::nth_element(sorted.begin(), sorted.begin() + std::ptrdiff_t(sorted.size() / 2), sorted.end());
        const double k = std::max(1.5 * sorted[sorted.size() / 2], 1e-5);
        for (std::size_t i = 0; i < t.size(); ++i) w[i] = res[i] <= k ? 1.0 : k / res[i];
    }
    double ss = 0;
    for (std::size_t i = 0; i < t.size(); ++i) {
        const double e = norm(minus(r[i], {a.x + b.x * t[i], a.y + b.y * t[i], a.z + b.z * t[i]}));
        ss += e * e;
    }
    if (line) {
        line->offset_rad = a;
        line->rate_rad_per_s = b;
        line->frames = int(t.size());
        line->residual_rms_deg = std::sqrt(ss / double(t.size())) * 180.0 / kPi;
    }
    const Quatd gauge = rotation_from_vector({-a.x, -a.y, -a.z});
    // Corrections against the sensor (world frame): trusted frames first, then the others.
    std::vector<Quatd> correction(frames.size());
    for (std::size_t i = 0; i < frames.size(); ++i)
        if (frames[i].trusted) correction[i] = firmware::normalized(gauge * frames[i].image * frames[i].sensor.conj());
    for (std::size_t i = 0; i < frames.size(); ++i) {
        if (frames[i].trusted) continue;
        std::ptrdiff_t best = -1;
        double best_dt = settings.hold_s;
        for (std::size_t j = 0; j < frames.size(); ++j)
            if (frames[j].trusted && std::abs(frames[j].t_s - frames[i].t_s) <= best_dt) {
                best_dt = std::abs(frames[j].t_s - frames[i].t_s);
                best = std::ptrdiff_t(j);
            }
        correction[i] = best >= 0 ? correction[std::size_t(best)]
                                  : rotation_from_vector({b.x * frames[i].t_s, b.y * frames[i].t_s, b.z * frames[i].t_s});
    }
    for (std::size_t i = 0; i < frames.size(); ++i) out.push_back(firmware::normalized(correction[i] * frames[i].sensor));
    return out;
}

}  // namespace glint::capture
