#include "appliance/capture/exposure_bands.hpp"

#include <algorithm>

namespace glint::capture {

Rgb merge_bands(std::span<const BandTexel> bands) {
    std::size_t cut = bands.size();
    bool shorter_confident = false;
    // Some shorter band read the texel and none of its reads there clipped.
    bool shorter_unclipped = false;
    for (std::size_t b = 0; b < bands.size(); ++b) {
        const BandTexel& x = bands[b];
        const double den = (x.den[0] + x.den[1] + x.den[2]) / 3;
        if (shorter_confident && x.clipped > 0) {
            cut = std::min(cut, b);
            break;
        }
        // Where most of a longer band's reads clipped, the few that did not are from frames that
        // placed the texel off the bright feature (brackets register a fraction of a pixel apart):
        // with Robertson's t^2 weight they would outweigh the shorter band's unclipped reads of it
        // even when those are too faint to be "confident" (docs/capture.md, "Exposure bands").
        if (shorter_unclipped && x.clipped > 0 && x.clipped >= kMostlyClipped * (x.clipped + x.reads)) {
            cut = std::min(cut, b);
            break;
        }
        if (!(den > 0) || !(x.wt > 0)) continue;
        if (x.clipped == 0) shorter_unclipped = true;
        double e_max = 0;
        for (int c = 0; c < 3; ++c)
            if (x.den[c] > 0) e_max = std::max(e_max, x.num[c] / x.den[c]);
        const double t_eff = den / x.wt;  // the band's typical exposure at this texel
        if (e_max * t_eff < kConfidentExposure) continue;
        shorter_confident = true;
        for (std::size_t c = b + 1; c < bands.size(); ++c) {
            // A band whose frames clipped here and whose clipped reads were all filled from
            // their brackets' shorter frames holds a complete sample of the texel: it stays.
            if (bands[c].filled > 0 && bands[c].clipped == 0) continue;
            if (e_max * bands[c].t_min > 1.0) {
                cut = std::min(cut, c);
                break;
            }
        }
    }
    double num[3] = {0, 0, 0}, den[3] = {0, 0, 0};
    for (std::size_t b = 0; b < cut; ++b)
        for (int c = 0; c < 3; ++c) {
            num[c] += bands[b].num[c];
            den[c] += bands[b].den[c];
        }
    // Dark reads are unbiased (a code 0 stands for the mean of the read noise it clipped,
    // below zero; HdrAccumulator::filtered_planes), so a texel of the dark can average a little
    // below zero: no radiance is.
    Rgb out{};
    out.r = den[0] > 0 ? float(std::max(0.0, num[0] / den[0])) : 0.0f;
    out.g = den[1] > 0 ? float(std::max(0.0, num[1] / den[1])) : 0.0f;
    out.b = den[2] > 0 ? float(std::max(0.0, num[2] / den[2])) : 0.0f;
    return out;
}

}  // namespace glint::capture
