// Exposure bands: Robertson's sums kept apart per band of exposure (4 stops wide), and merged per
// texel at the end with a consistency rule, so that a misregistered long exposure cannot erase a
// sun that only the short exposures hold.
//
// Why: Robertson's estimator weights a frame by w t^2. Where a long exposure clips, its reads
// are no samples (hdr_accumulator.hpp), but a frame registered a fraction of a degree off puts
// valid sky where a short exposure put the sun, and its t^2 (4096^2 for a bracket 12 stops
// shorter) makes the sky win: the sun of sunset.exr lost 85 % of its energy within 4 texels with
// the sensor's orientations.
//
// The rule: a band b whose estimate here is measured well above its noise (relative exposure
// E_b t_eff >= kConfidentExposure in the brightest channel) says the radiance is E_b. Any longer
// band c whose shortest frame would have clipped at that radiance (E_b t_min(c) > 1) cannot hold
// a valid read of it, so c and every longer band are left out at this texel. The same holds for
// a longer band c some of whose reads here clipped (`clipped` > 0) once a shorter band measured
// the texel: the reads that remain are a censored sample (the frames, a fraction of a degree
// apart, that put the source beside this texel), low by what the clipped ones held. Beside a
// 1e-5 sr source that censoring, not registration, cost 7.5-11 % of its energy (docs/capture.md,
// "Censored bands"). Everything else merges as one Robertson sum, so a dim texel keeps the low
// noise of the long exposures.
#pragma once

#include <algorithm>
#include <cmath>
#include <span>
#include <vector>

#include "appliance/core/hdr_image.hpp"

namespace glint::capture {

// Width of a band in stops of exposure x gain: 4. The bracket steps (6 stops apart) never share a
// band. The exposure controller's top-up frame is kept a whole band (4 stops) below the bracket
// step that clipped, so it never shares that step's band either: sharing it, its unclipped reads
// kept the step's misregistered reads beside a source in the merge (dim_1e+06 seed 2's 1e-5 sr
// source: -18.7 % with the top-up 2 stops under the step). Two-stop bands also separate them
// (the default for a few hours on 2026-12-05), but cost studio's irradiance 0.31 -> 0.40 %;
// four-stop bands with the top-up a band down gave 0.25 % (docs/capture.md "Exposure control",
// "Top-up and bands").
// Each band in use costs 10 floats a texel on the CPU (21 MB at 1024x512) and 25 MB of GPU targets.
inline constexpr double kBandStops = 4;
inline constexpr double kConfidentExposure = 0.02;  // 10x the read noise of the simulated sensor
// A longer band is left out where a shorter band read the texel without clipping and at least
// this share of the longer band's reads there clipped (merge_bands).
inline constexpr double kMostlyClipped = 0.5;

// The band of an exposure t (exposure x gain x sensitivity, > 0).
inline int exposure_band(double t) { return int(std::floor(std::log2(t) / kBandStops)); }

// The band of exposure t in `bands` (kept sorted by index; a Band has `int index` and
// `double t_min`), made by make(index) when it is the first frame of its band; t_min follows t.
// Shared by the CPU and GPU accumulators, whose bands hold their sums differently.
template <typename Band, typename Make>
Band& band_for_exposure(std::vector<Band>& bands, double t, Make make) {
    const int index = exposure_band(t);
    auto it = std::lower_bound(bands.begin(), bands.end(), index, [](const Band& b, int i) { return b.index < i; });
    if (it == bands.end() || it->index != index) {
        Band b = make(index);
        b.index = index;
        b.t_min = t;
        it = bands.insert(it, std::move(b));
    }
    it->t_min = std::min(it->t_min, t);
    return *it;
}

// One band's sums at one texel.
struct BandTexel {
    double num[3];  // sum W t X per channel
    double den[3];  // sum W t^2 per channel
    double wt;      // sum W t (W the mean of the channels' weights)
    double clipped; // reads of this band at this texel left out because they clipped
    double reads;   // reads of this band at this texel that did not clip (filled ones included)
    double filled;  // ... of which filled from a shorter frame of the clipped frame's bracket
    double t_min;   // shortest exposure of any frame in the band (the whole band, not this texel)
};

// Merged radiance at a texel from its bands, shortest band first; 0 where no band has weight.
Rgb merge_bands(std::span<const BandTexel> bands);

}  // namespace glint::capture
