// The error metrics of docs/conventions.md ("Error between two maps").
#pragma once

#include "appliance/core/equirect.hpp"
#include "appliance/core/hdr_image.hpp"

namespace glint {

struct MapError {
    // sqrt( sum dOmega |A-B|^2 / sum dOmega |B|^2 ) over all texels and channels.
    double weighted_relative_rms = 0;
    // max_k |A_k - B_k| / max(|B_k|, mean|B|) over all texels and channels.
    double worst_texel = 0;
    // Thesis eq. 6.1 / 6.2: |a - v| / (a + eps), eps = 1e-6 mean(a), a = reference.
    double mean_abs_percent = 0;  // in percent
    double max_abs_percent = 0;   // in percent
};

// Error of `approx` against `reference`. If the sizes differ, `approx` is first
// resampled bilinearly to the reference's texel centres, as a renderer would.
MapError compare_maps(const HdrImage& approx, const HdrImage& reference);
// The same for a map read by `lookup`: a lobe-lookup map (report.json "lookup": "lobe", its texels
// the input's radiance) is read through its lobe of `shininess` at the reference's texel centres
// (resample_lobe), whatever the two sizes; a bilinear map as above.
MapError compare_maps(const HdrImage& approx, const HdrImage& reference, MapLookup lookup, double shininess);

}  // namespace glint
