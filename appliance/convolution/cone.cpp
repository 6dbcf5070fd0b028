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

BrightSplit split_bright(const HdrImage& input, double contrast, int max_count) {
    const int w = input.width();
    const int h = input.height();
    const std::vector<double> omega = row_solid_angles(w, h);
    double mean = 0;
    for (int j = 0; j < h; ++j) {
        const float* row = input.row(j);
        double s = 0;
        for (int i = 0; i < w; ++i) s += std::max({row[3 * i], row[3 * i + 1], row[3 * i + 2]});
        mean += s * omega[std::size_t(j)];
    }
    mean /= 4.0 * kPi;

    BrightSplit split;
    split.remainder = input;
    split.threshold = contrast * mean;
    if (!(mean > 0) || max_count <= 0) return split;

    struct Candidate {
        float value;
        int i, j;
    };
    std::vector<Candidate> candidates;
    for (int j = 0; j < h; ++j) {
        const float* row = input.row(j);
        for (int i = 0; i < w; ++i) {
            const float v = std::max({row[3 * i], row[3 * i + 1], row[3 * i + 2]});
            if (double(v) > split.threshold) candidates.push_back({v, i, j});
        }
    }
    std::sort(candidates.begin(), candidates.end(), [](const Candidate& a, const Candidate& b) {
        return a.value > b.value || (a.value == b.value && (a.j < b.j || (a.j == b.j && a.i < b.i)));
    });
    if (int(candidates.size()) > max_count) candidates.resize(std::size_t(max_count));
    for (const Candidate& c : candidates) {
        const Rgb l = input.at(c.i, c.j);
        const double om = omega[std::size_t(c.j)];
        const double theta = row_theta(c.j, h);
        const double phi = column_phi(c.i, w);
        const Vec3 d = direction_from_angles(theta, phi);
        split.texels.push_back({d.x, d.y, d.z, theta, phi, l.r * om, l.g * om, l.b * om});
        split.remainder.set(c.i, c.j, {0, 0, 0});
    }
    return split;
}

namespace {

// x^n for x in [0, 1]: binary exponentiation when n is a small integer (the
// common case, ~2 log2(n) multiplies), std::pow otherwise.
double power(double x, double n) {
    if (n == std::floor(n) && n < 1e6) {
        double result = 1.0;
        double base = x;
        for (long long e = (long long)n; e > 0; e >>= 1) {
            if (e & 1) result *= base;
            base *= base;
        }
        return result;
    }
    return std::pow(x, n);
}

// Adds the bright texels' terms (relative to the output texel's cmax, like the
// lobe sums) to nb for one output row. cos_phi/sin_phi: output column azimuths.
void scatter_bright_row(int row, const std::vector<BrightTexel>& bright,
                        const std::vector<double>& min_cos, const LobeSums& sums, double n,
                        const std::vector<double>& cos_phi, const std::vector<double>& sin_phi,
                        std::vector<double>& nb) {
    const int ow = sums.out_w;
    const double theta_r = row_theta(row, sums.out_h);
    const double ct = std::cos(theta_r);
    const double st = std::sin(theta_r);
    const double* cmax_row = sums.cmax.data() + std::size_t(row) * std::size_t(sums.classes);
    double* nb_row = nb.data() + std::size_t(row) * std::size_t(ow) * 3;
    for (std::size_t k = 0; k < bright.size(); ++k) {
        const BrightTexel& b = bright[k];
        const double c_b = min_cos[k];
        if (c_b > 1.0) continue;
        if (std::cos(theta_r - b.theta) < c_b) continue;  // no column of this row reaches
        const double a = st * std::sin(b.theta);
        const double bq = ct * b.y;  // b.y = cos(theta_b)
        int first, count;
        const double q = a > 1e-300 ? (c_b - bq) / a : (bq >= c_b ? -2.0 : 2.0);
        if (q > 1.0) continue;
        if (q <= -1.0) {
            first = 0;
            count = ow;
        } else {
            const double centre = (b.phi + kPi) / kTwoPi * ow - 0.5;  // output column units
            const double half = std::acos(q) / kTwoPi * ow;
            first = int(std::floor(centre - half)) - 1;  // one column of margin: weights decide
            count = std::min(ow, int(std::ceil(centre + half)) + 1 - first + 1);
        }
        const double cpb = std::cos(b.phi), spb = std::sin(b.phi);
        for (int t = 0; t < count; ++t) {
            int i = (first + t) % ow;
            if (i < 0) i += ow;
            const double cosine = a * (cos_phi[std::size_t(i)] * cpb + sin_phi[std::size_t(i)] * spb) + bq;
            if (!(cosine > 0)) continue;
            const double cm = cmax_row[sums.class_of(i)];
            const double wgt = n == 0 ? 1.0 : power(std::min(1.0, cosine / cm), n);
            double* o = nb_row + 3 * std::size_t(i);
            o[0] += wgt * b.r;
            o[1] += wgt * b.g;
            o[2] += wgt * b.b;
        }
    }
}

}  // namespace

HdrImage cone_convolve(const PreparedLevel& level, const std::vector<BrightTexel>& bright,
                       double n, Size out, const ConeSettings& settings, int threads,
                       const RowProgress& progress, ConeStats* stats) {
    const LobeSummer summer(level, out.width, out.height, n);
    LobeSums sums = summer.make_sums();
    const auto cut_cos = [n](double energy) {
        return energy > 0 ? std::pow(std::min(1.0, energy), 1.0 / (n + 1.0)) : 0.0;
    };
    const double c0 = cut_cos(settings.cutoff_energy);
    parallel_for(out.height, threads, [&](int row) {
        summer.sum_row(row, c0, sums);
        if (progress) progress(1);
    });

    const std::size_t texels = std::size_t(out.width) * std::size_t(out.height);
    // Cut-off cosine used for each output row (rows may be refined below).
    std::vector<double> row_cut(std::size_t(out.height), c0);
    // The remainder's lobe weight outside the row's cone, from the continuous
    // lobe: sum of (cos/cmax)^n dOmega over cos < c is 2pi c^(n+1) / ((n+1) cmax^n).
    const auto outside_weight = [&](std::size_t row, double cmax) {
        const double c = row_cut[row];
        if (c <= 0) return 0.0;
        return kTwoPi / (n + 1.0) * std::exp((n + 1.0) * std::log(c) - n * std::log(cmax));
    };
    // E = N_R / D_R + N_B / (D_R + D_out): the remainder outside the cone is
    // taken at the inside's mean (its error is the bound above), while the bright
    // terms, summed over the whole sphere, are divided by the whole lobe weight.
    const auto value = [&](std::size_t t, int c, const std::vector<double>& nb) {
        const std::size_t row = t / std::size_t(out.width);
        const int col = int(t % std::size_t(out.width));
        const std::size_t rc = row * std::size_t(sums.classes) + std::size_t(sums.class_of(col));
        const double den = sums.den[rc];
        if (!(den > 0)) return 0.0;
        const double bright_part = nb[3 * t + std::size_t(c)];
        const double remainder = sums.num[3 * t + std::size_t(c)] / den;
        return bright_part == 0 ? remainder : remainder + bright_part / (den + outside_weight(row, sums.cmax[rc]));
    };

    std::vector<double> nb(3 * texels, 0.0);
    if (!bright.empty()) {
        // Smallest positive output so far: a bright term below bright_tolerance
        // of it (and so of every output) may be dropped.
        double floor_value = INFINITY;
        for (std::size_t t = 0; t < texels; ++t)
            for (int c = 0; c < 3; ++c) {
                const double v = value(t, c, nb);
                if (v > 0) floor_value = std::min(floor_value, v);
            }
        if (!std::isfinite(floor_value)) floor_value = 0;
        const double lobe_den = kTwoPi / (n + 1.0);  // sum of weights, continuous, cmax ~ 1
        std::vector<double> min_cos(bright.size());
        for (std::size_t k = 0; k < bright.size(); ++k) {
            const double peak = std::max({bright[k].r, bright[k].g, bright[k].b});
            const double ratio = settings.bright_tolerance * floor_value * lobe_den / peak;
            // Weight ratio below which the term is negligible; as a cosine. The
            // 0.999 allows for cmax < 1 on coarse grids.
            min_cos[k] = n == 0 ? 0.0 : (ratio >= 1.0 ? 2.0 : 0.999 * std::pow(ratio, 1.0 / n));
        }
        std::vector<double> cos_phi(std::size_t(out.width)), sin_phi(std::size_t(out.width));
        for (int i = 0; i < out.width; ++i) {
            cos_phi[std::size_t(i)] = std::cos(column_phi(i, out.width));
            sin_phi[std::size_t(i)] = std::sin(column_phi(i, out.width));
        }
        parallel_for(out.height, threads, [&](int row) {
            scatter_bright_row(row, bright, min_cos, sums, n, cos_phi, sin_phi, nb);
        });
    }

    // Per-row refinement where the cut-off bound is not met.
    const double lmax = level.max_value();
    ConeStats local;
    std::vector<double> row_energy(std::size_t(out.height), settings.cutoff_energy);
    for (int row = 0; row < out.height; ++row) {
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
    for (int row = 0; row < out.height; ++row)
        if (row_energy[std::size_t(row)] < settings.cutoff_energy) refine_rows.push_back(row);
    parallel_for(int(refine_rows.size()), threads, [&](int k) {
        const int row = refine_rows[std::size_t(k)];
        summer.sum_row(row, row_cut[std::size_t(row)], sums);
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
