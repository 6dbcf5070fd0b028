// Which part of the sphere a capture has seen, the direction of what is missing, and the rule
// for what the camera cannot see (docs/capture.md "Coverage and the unseen floor").
#pragma once

#include <cstdint>
#include <vector>

#include "appliance/core/equirect.hpp"
#include "appliance/core/hdr_image.hpp"

namespace glint::capture {

struct CoverageReport {
    double covered_fraction = 0;   // solid-angle share of texels with >= min_samples samples
    glm::dvec3 largest_gap{0, -1, 0};  // centre of the cap (radius gap_radius) holding the most unseen
    double largest_gap_sr = 0;     // unseen solid angle inside that cap, steradians
};

// samples: per texel (row-major, width x height) frames that sampled it.
CoverageReport measure_coverage(const std::vector<std::uint32_t>& samples, int width, int height, int min_samples,
                                double gap_radius_rad = 0.5);

// The samples of a finished map: a texel that no single frame sampled with a usable weight but
// whose weights sum to min_weight or more counts as sampled once. Several weak samples (a bright
// source near the lower edge of what the scan sees, met only by frames whose weight there is
// small) carry its radiance; without this the fill replaced it with the floor's mean (a 1e-2 sr
// source at -72 degrees lost 20 % of its energy). weights: the accumulator's summed W per texel.
std::vector<std::uint32_t> samples_with_summed_weight(std::vector<std::uint32_t> samples,
                                                      const std::vector<float>& weights, double min_weight);

// Fills every texel with fewer than min_samples samples, in place; returns how many it filled.
// Rule: in each column, a gap between two covered texels is interpolated linearly in polar angle
// between them; the texels above the first covered one (the zenith cap) take the mean of the
// first covered texel of every column, those below the last one (the floor under the stand, the
// visitor) the mean of the last covered texel of every column: the nearest covered ring. Columns
// with no covered texel take the solid-angle mean of everything covered. With nothing covered
// the map stays as it is.
long long fill_uncovered(HdrImage& radiance, const std::vector<std::uint32_t>& samples, int min_samples);

// The coverage map saved beside the environment map: R = samples, G = summed weight, B = 1 where
// covered (samples >= min_samples), else 0.
HdrImage coverage_image(const std::vector<std::uint32_t>& samples, const std::vector<float>& weights, int width,
                        int height, int min_samples);

}  // namespace glint::capture
