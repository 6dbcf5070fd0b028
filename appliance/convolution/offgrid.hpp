// An independent judge of a convolved map's error where a renderer reads it: at
// any direction, by bilinear lookup, not only at the map's own texel centres.
//
//   A(r) = sample_bilinear(map, r)          what the renderer sees
//   B(r) = E^n(r)                            the conventions' sum over every input texel
//
// B is written here from docs/conventions.md ("Reflection and irradiance maps")
// without lobe_sum.hpp, which it is meant to judge: every input texel centre with
// r.w > 0, weights (r.w / cmax(r))^n relative to the largest cosine, sums in double.
// A mirror (shininess = +infinity) reads the environment itself as a renderer
// does: B = sample_bilinear(input, r).
//
// The errors are the conventions' ("Error between two maps") with the sum over
// texels replaced by the integral over the sphere, estimated by Monte Carlo.
#pragma once

#include <cstdint>
#include <vector>

#include <glm/glm.hpp>

#include "appliance/core/equirect.hpp"
#include "appliance/core/fine_tiles.hpp"
#include "appliance/core/hdr_image.hpp"

namespace glint::convolution {

// E^n(r) of the conventions for one direction r (need not be unit length, must
// not be zero), in double. Terms whose weight relative to the largest is below
// 1e-300 are skipped (they cannot change a double sum): whole rows by the bound
// cos|theta_r - theta_k| on their best cosine, and per row the columns outside
// the azimuth range that can pass. n = +infinity: sample_bilinear(input, r).
// Zero if no texel centre has r.w > 0 (a 1x1 map seen from behind).
// Throws InputError on an empty input, a negative or NaN shininess.
glm::dvec3 exact_at_double(const HdrImage& input, double shininess, const glm::dvec3& r);
// The same rounded to float once.
Rgb exact_at(const HdrImage& input, double shininess, const glm::dvec3& r);

// The evaluator behind exact_at, with the input's per-row and per-column tables
// built once (measure_offgrid_error calls it for every sample). Thread-safe.
class ExactAt {
public:
    ExactAt(const HdrImage& input, double shininess);
    glm::dvec3 operator()(const glm::dvec3& r) const;

private:
    const HdrImage* input_;
    double n_;
    bool mirror_;
    int w_, h_;
    std::vector<double> cos_t_, sin_t_, theta_, omega_;  // per row
    std::vector<double> cos_p_, sin_p_;                   // per column
};

struct OffGridError {
    // sqrt( integral |A-B|^2 dOmega / integral |B|^2 dOmega ), channels summed,
    // estimated by the self-normalised ratio of the samples' |A-B|^2/p and |B|^2/p.
    double weighted_relative_rms = 0;
    // Standard error of weighted_relative_rms (delta method, samples taken as
    // independent draws from the mixture; the fixed half/half split makes the
    // true error a little smaller).
    double rms_standard_error = 0;
    // max over samples and channels of |A-B| / max(|B|, mean_abs_reference).
    double worst_texel = 0;
    int samples = 0;
    // The floor of worst_texel: the solid-angle mean of |B| over the sphere and
    // the three channels, estimated from the same samples (sum |B|/p / (3 N 4 pi)).
    double mean_abs_reference = 0;
    glm::dvec3 worst_direction{0, 0, 0};
    int worst_channel = 0;
    double worst_approx = 0, worst_reference = 0;  // A and B of that channel there
};

// Error of bilinear lookups in `map` against exact_at(input, shininess, r) at
// `samples` random directions: the first half (rounded up) uniform on the
// sphere, the rest drawn from the map itself (a texel with probability
// proportional to dOmega |value|^2, channels summed, then a uniform direction
// inside its footprint), so that a small bright source, which dominates both
// integrals, is not missed. Each sample is weighted by 1/p with p the density
// of the whole mixture (per steradian, the balance heuristic). Sample i draws
// from its own random stream (seed, i), and the sums are taken in sample order,
// so the result does not depend on `threads` (<= 0: all hardware threads).
// Throws InputError on an empty image, samples < 1, or a bad shininess.
// `lookup`: how the renderer reads `map` (MapPlan::lookup, report.json's "lookup": the lobe
// lookup for a lobe narrower than half the input's texels, whose map holds the input's texels).
// `fine`: the map's fine tiles (MapResult::fine), read through them (core/fine_tiles.hpp).
OffGridError measure_offgrid_error(const HdrImage& input, const HdrImage& map, double shininess, int samples,
                                   std::uint64_t seed, int threads, MapLookup lookup = MapLookup::Bilinear,
                                   const FineTiles* fine = nullptr);

}  // namespace glint::convolution
