#include "appliance/capture/drift_correction.hpp"

#include <algorithm>
#include <cmath>

#include "appliance/capture/hdr_accumulator.hpp"
#include "appliance/capture/rotation_fit.hpp"
#include "appliance/core/equirect.hpp"

namespace glint::capture {

namespace {

struct GridPixel {
    glm::dvec3 ray;       // camera frame
    double log_lum;       // log luminance of the frame's radiance estimate
};

}  // namespace

DriftEstimate DriftCorrector::estimate(const CameraFrame& frame, const CameraCalibration& cal,
                                       const glm::dquat& world_from_camera, const HdrImage& sphere,
                                       const std::vector<std::uint32_t>& samples) {
    DriftEstimate out = measure(frame, cal, world_from_camera, sphere, samples);
    if (!out.applied) return out;  // not trusted: keep the previous correction
    // Low-pass of the measured offset: a slowly growing sensor drift is followed in full, while the
    // noise of single alignments averages out instead of being applied (or chained) frame by frame.
    const glm::dquat measured = out.correction;
    carried_ = unit_rotation(glm::slerp(carried_, measured, settings_.gain));
    // This frame: the slow part, plus a share of what this frame's own alignment says beyond it.
    out.correction = unit_rotation(glm::slerp(carried_, measured, settings_.frame_share));
    return out;
}

DriftEstimate DriftCorrector::measure(const CameraFrame& frame, const CameraCalibration& cal,
                                      const glm::dquat& world_from_camera, const HdrImage& sphere,
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
            grid.push_back({pixel_ray(k, pu, pv), std::log(lum / 3)});
        }
    // Residuals of a candidate world-frame correction; pixels whose texel is not covered drop out.
    const auto residuals = [&](const glm::dvec3& delta, std::vector<double>& r) {
        const glm::dquat q = rotation_from_vector(delta) * world_from_camera;
        r.assign(grid.size(), std::nan(""));
        for (std::size_t i = 0; i < grid.size(); ++i) {
            const glm::dvec3 d = q * grid[i].ray;
            const TexelCoord tc = direction_to_texel(d, w, h);
            const int ti = std::clamp(int(tc.x), 0, w - 1), tj = std::clamp(int(tc.y), 0, h - 1);
            if (samples[std::size_t(tj) * std::size_t(w) + std::size_t(ti)] == 0) continue;
            const Rgb e = sample_bilinear(sphere, d);
            const double lum = (double(e.r) + double(e.g) + double(e.b)) / 3;
            if (!(lum > 0)) continue;
            r[i] = grid[i].log_lum - std::log(lum);
        }
    };
    RotationFitSettings fit_settings;
    fit_settings.iterations = settings_.iterations;
    fit_settings.min_points = settings_.min_pixels;
    const RotationFit fit = fit_rotation(residuals, fit_settings);
    out.residual_before = fit.cost_before;
    out.residual_after = fit.cost_after;
    out.pixels = fit.points;
    if (fit.points < settings_.min_pixels) return out;
    out.angle_deg = glm::length(fit.delta) * 180.0 / kPi;
    out.sigma_deg = fit.sigma_rad * 180.0 / kPi;
    if (out.angle_deg > settings_.max_correction_deg || !(fit.cost_after <= out.residual_before) ||
        out.sigma_deg > settings_.max_sigma_deg) {
        out.residual_after = out.residual_before;
        return out;  // not trusted
    }
    out.correction = rotation_from_vector(fit.delta);
    out.applied = true;
    return out;
}

}  // namespace glint::capture
