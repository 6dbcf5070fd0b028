#include "appliance/capture/exposure_bands.hpp"

#include <algorithm>

namespace glint::capture {

Rgb merge_bands(std::span<const BandTexel> bands) {
    std::size_t cut = bands.size();
    bool shorter_confident = false;
    for (std::size_t b = 0; b < bands.size(); ++b) {
        const BandTexel& x = bands[b];
        const double den = (x.den[0] + x.den[1] + x.den[2]) / 3;
        if (shorter_confident && x.clipped > 0) {
            cut = std::min(cut, b);
            break;
        }
        if (!(den > 0) || !(x.wt > 0)) continue;
        double e_max = 0;
        for (int c = 0; c < 3; ++c)
            if (x.den[c] > 0) e_max = std::max(e_max, x.num[c] / x.den[c]);
        const double t_eff = den / x.wt;  // the band's typical exposure at this texel
        if (e_max * t_eff < kConfidentExposure) continue;
        shorter_confident = true;
        for (std::size_t c = b + 1; c < bands.size(); ++c)
            if (e_max * bands[c].t_min > 1.0) {
                cut = std::min(cut, c);
                break;
            }
    }
    double num[3] = {0, 0, 0}, den[3] = {0, 0, 0};
    for (std::size_t b = 0; b < cut; ++b)
        for (int c = 0; c < 3; ++c) {
            num[c] += bands[b].num[c];
            den[c] += bands[b].den[c];
        }
    Rgb out{};
    out.r = den[0] > 0 ? float(num[0] / den[0]) : 0.0f;
    out.g = den[1] > 0 ? float(num[1] / den[1]) : 0.0f;
    out.b = den[2] > 0 ? float(num[2] / den[2]) : 0.0f;
    return out;
}

}  // namespace glint::capture
