// Map error metrics; every sum in double, solid angles exact per row.
#include "appliance/core/error_metrics.hpp"

#include <algorithm>
#include <cmath>

#include "appliance/core/equirect.hpp"

namespace glint {

namespace {

// The metrics of two maps on the same grid.
MapError compare_same_grid(const HdrImage& approx, const HdrImage& reference) {
    const int w = reference.width();
    const int h = reference.height();
    const std::vector<double> omega = row_solid_angles(w, h);

    double mean_abs_ref = 0;
    for (float v : reference.data()) mean_abs_ref += std::abs(double(v));
    mean_abs_ref /= double(reference.data().size());
    const double eps = 1e-6 * mean_abs_ref;
    const double worst_floor = mean_abs_ref > 0 ? mean_abs_ref : 1e-300;

    MapError e;
    double num = 0, den = 0, pct_sum = 0;
    for (int j = 0; j < h; ++j) {
        const float* a = approx.row(j);
        const float* b = reference.row(j);
        double row_num = 0, row_den = 0;
        for (int k = 0; k < 3 * w; ++k) {
            const double diff = std::abs(double(a[k]) - double(b[k]));
            const double ref = std::abs(double(b[k]));
            row_num += diff * diff;
            row_den += ref * ref;
            e.worst_texel = std::max(e.worst_texel, diff / std::max(ref, worst_floor));
            // An all-black reference makes eps 0: equal values are then 0 % off, not 0/0.
            const double pct = diff == 0 ? 0.0 : 100.0 * diff / (double(b[k]) + eps);
            pct_sum += pct;
            e.max_abs_percent = std::max(e.max_abs_percent, pct);
        }
        num += omega[std::size_t(j)] * row_num;
        den += omega[std::size_t(j)] * row_den;
    }
    e.weighted_relative_rms = den > 0 ? std::sqrt(num / den) : (num > 0 ? INFINITY : 0.0);
    e.mean_abs_percent = pct_sum / double(reference.data().size());
    return e;
}

}  // namespace

MapError compare_maps(const HdrImage& approx, const HdrImage& reference) {
    return compare_maps(approx, reference, MapLookup::Bilinear, 0.0);
}

MapError compare_maps(const HdrImage& approx, const HdrImage& reference, MapLookup lookup, double shininess) {
    // A lobe map's texel holds radiance, not the lobe's sum: even on the reference's own grid it
    // is read through the lobe.
    if (lookup == MapLookup::Lobe)
        return compare_same_grid(resample_lobe(approx, reference.width(), reference.height(), shininess), reference);
    if (approx.width() == reference.width() && approx.height() == reference.height())
        return compare_same_grid(approx, reference);
    return compare_same_grid(resample_bilinear(approx, reference.width(), reference.height()), reference);
}

}  // namespace glint
