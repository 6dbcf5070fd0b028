// The cone method: lobe sums inside the cut-off cone on a pyramid level, with
// the brightest texels summed exactly and a per-row error bound that widens
// the cone where a dark texel sits near bright ones.
//
// Cut-off (DESIGN.md): the normalised Phong lobe (n+1)/(2pi) cos^n holds
//   integral_{cos a < c} = c^(n+1)
// of its energy outside the cone cos a >= c, so dropping a fraction e of the
// lobe means c = e^(1/(n+1)).
//
// Error bound of dropping the outside: with weights W_in inside and W_out
// outside (W_out / (W_in + W_out) ~ e) and the outside radiance at most Lmax,
//   E - E' = W_out (L_out - E') / (W_in + W_out)  =>  |E - E'| <= e max(Lmax - E', E').
#include <algorithm>
#include <cmath>

#include "appliance/convolution/methods.hpp"
#include "appliance/core/equirect.hpp"
#include "appliance/core/parallel.hpp"

namespace glint::convolution {

HdrImage cone_convolve(const PreparedLevel& level, const std::vector<BrightTexel>& bright,
                       double n, Size out, const ConeSettings& settings, int threads,
                       const RowProgress& progress, ConeStats* stats, const std::vector<int>& only_rows) {
    // The output rows computed: all, or only_rows (the others stay 0).
    std::vector<int> rows = only_rows;
    if (rows.empty())
        for (int row = 0; row < out.height; ++row) rows.push_back(row);
    const LobeSummer summer(level, out.width, out.height, n);
    LobeSums sums = summer.make_sums();
    const auto cut_cos = [n](double energy) {
        return energy > 0 ? std::pow(std::min(1.0, energy), 1.0 / (n + 1.0)) : 0.0;
    };
    const double c0 = cut_cos(settings.cutoff_energy);
    parallel_for(int(rows.size()), threads, [&](int k) {
        summer.sum_row(rows[std::size_t(k)], c0, sums);
        if (progress) progress(1);
    });

    const std::size_t texels = std::size_t(out.width) * std::size_t(out.height);
    // Cut-off cosine used for each output row (rows may be refined below).
    std::vector<double> row_cut(std::size_t(out.height), c0);
    // Per (row, class): 1 / D_R and 1 / (D_R + D_out), where D_out is the
    // remainder's lobe weight outside the row's cone, from the continuous lobe:
    // sum of (cos/cmax)^n dOmega over cos < c is 2pi c^(n+1) / ((n+1) cmax^n).
    std::vector<double> inv_den(sums.den.size()), inv_full_den(sums.den.size());
    const auto update_denominators = [&](int row) {
        const double c = row_cut[std::size_t(row)];
        for (int cls = 0; cls < sums.classes; ++cls) {
            const std::size_t rc = std::size_t(row) * std::size_t(sums.classes) + std::size_t(cls);
            const double den = sums.den[rc];
            const double outside =
                c > 0 ? kTwoPi / (n + 1.0) * std::exp((n + 1.0) * std::log(c) - n * std::log(sums.cmax[rc])) : 0.0;
            inv_den[rc] = den > 0 ? 1.0 / den : 0.0;
            inv_full_den[rc] = den > 0 ? 1.0 / (den + outside) : 0.0;
        }
    };
    for (int row = 0; row < out.height; ++row) update_denominators(row);
    // E = N_R / D_R + N_B / (D_R + D_out): the remainder outside the cone is
    // taken at the inside's mean (its error is the bound above), while the bright
    // terms, summed over the whole sphere, are divided by the whole lobe weight.
    const auto value = [&](std::size_t t, int c, const std::vector<double>& nb) {
        const std::size_t row = t / std::size_t(out.width);
        const int col = int(t % std::size_t(out.width));
        const std::size_t rc = row * std::size_t(sums.classes) + std::size_t(sums.class_of(col));
        return sums.num[3 * t + std::size_t(c)] * inv_den[rc] + nb[3 * t + std::size_t(c)] * inv_full_den[rc];
    };

    std::vector<double> nb(3 * texels, 0.0);
    if (!bright.empty()) {
        double floor_value = INFINITY;
        for (std::size_t t = 0; t < texels; ++t)
            for (int c = 0; c < 3; ++c) {
                const double v = value(t, c, nb);
                if (v > 0) floor_value = std::min(floor_value, v);
            }
        scatter_bright(bright, n, out, sums.cmax, sums.classes,
                       std::isfinite(floor_value) ? floor_value : 0.0, settings.bright_tolerance, threads, nb,
                       rows);
    }

    // Per-row refinement where the cut-off bound is not met.
    const double lmax = level.max_value();
    ConeStats local;
    std::vector<double> row_energy(std::size_t(out.height), settings.cutoff_energy);
    for (int row : rows) {
        double need = settings.cutoff_energy;
        for (int i = 0; i < out.width; ++i) {
            const std::size_t t = std::size_t(row) * std::size_t(out.width) + std::size_t(i);
            for (int c = 0; c < 3; ++c) {
                const double e = value(t, c, nb);
                const double spread = std::max(lmax - e, e);
                if (spread > 0) need = std::min(need, settings.texel_tolerance * e / spread);
            }
        }
        if (need < settings.cutoff_energy * 0.999) {
            row_energy[std::size_t(row)] = need;
            row_cut[std::size_t(row)] = cut_cos(need);
            ++local.refined_rows;
            local.refined_texels += out.width;
        }
    }
    std::vector<int> refine_rows;
    for (int row : rows)
        if (row_energy[std::size_t(row)] < settings.cutoff_energy) refine_rows.push_back(row);
    parallel_for(int(refine_rows.size()), threads, [&](int k) {
        const int row = refine_rows[std::size_t(k)];
        summer.sum_row(row, row_cut[std::size_t(row)], sums);
        update_denominators(row);
    });
    if (stats) *stats = local;

    HdrImage result(out.width, out.height);
    for (std::size_t t = 0; t < texels; ++t) {
        float* o = result.data().data() + 3 * t;
        for (int c = 0; c < 3; ++c) o[c] = float(std::max(0.0, value(t, c, nb)));
    }
    return result;
}

}  // namespace glint::convolution
