// The cone method: lobe sums inside the cut-off cone on a pyramid level, with
// the brightest texels summed exactly and a per-row error bound that widens
// the cone where a dark texel sits near bright ones.
//
// Cut-off (docs/convolution.md, "Cone"): the normalised Phong lobe (n+1)/(2pi) cos^n holds
//   integral_{cos a < c} = c^(n+1)
// of its energy outside the cone cos a >= c, so dropping a fraction e of the
// lobe means c = e^(1/(n+1)).
//
// Error bound of dropping the outside: with weights W_in inside and W_out
// outside (W_out / (W_in + W_out) ~ e) and the outside radiance at most Lmax,
//   E - E' = W_out (L_out - E') / (W_in + W_out)  =>  |E - E'| <= e max(Lmax - E', E').
#include <algorithm>
#include <cmath>
#include <cstring>
#include <memory>

#include "appliance/convolution/fourier_pass.hpp"
#include "appliance/convolution/methods.hpp"
#include "appliance/core/equirect.hpp"
#include "appliance/core/errors.hpp"
#include "appliance/core/lane_extrema.hpp"
#include "appliance/core/parallel.hpp"

namespace glint::convolution {


namespace {

// The cone's sums on the CPU: LobeSummer with float runs and merged polar columns.
class CpuConeSums final : public ConeSumsBackend {
public:
    // columns: per row of first_pass's rows, the texels summed (null: all).
    // fourier: sum the first pass by Fourier transforms (whole rows; FourierFirstPass::pays_off).
    CpuConeSums(const PreparedLevel& level, Size out, double n, const ConeSettings& settings, int threads,
                const std::vector<LobeSummer::ColumnRuns>* columns, bool fourier)
        : summer_(level, out.width, out.height, n, Accumulation::FloatRuns, settings.max_texel_arc,
                  settings.max_arc_roughness),
          threads_(threads), columns_(columns) {
        if (fourier) fourier_ = std::make_unique<FourierFirstPass>(summer_, out.width, threads);
    }

    bool fourier() const { return fourier_ != nullptr; }

    LobeSums first_pass(const std::vector<int>& rows, double c0, const RowProgress& progress) override {
        // With column runs (patches of a finer grid), only those texels' windows are stored.
        LobeSums sums = summer_.make_sums(&rows, columns_);
        if (fourier_) {
            fourier_->run(rows, c0, sums, progress);
            return sums;
        }
        summer_.lay_out();
        parallel_for(int(rows.size()), threads_, [&](int k) {
            summer_.sum_row(rows[std::size_t(k)], c0, sums, columns_ ? &(*columns_)[std::size_t(k)] : nullptr);
            if (progress) progress(1);
        });
        return sums;
    }
    LobeSums annulus(const std::vector<int>& rows, const std::vector<LobeSummer::ColumnRuns>& runs,
                     const std::vector<double>& cut, double c_inner) override {
        LobeSums sums = summer_.make_sums(&rows, &runs);
        summer_.lay_out();
        parallel_for(int(rows.size()), threads_, [&](int k) {
            summer_.sum_row(rows[std::size_t(k)], cut[std::size_t(k)], sums, &runs[std::size_t(k)], c_inner);
        });
        return sums;
    }
    void bright(const BrightScatter& scatter, const LobeSums& sums, const std::vector<int>& rows,
                UninitVector<double>& nb) override {
        parallel_for(int(rows.size()), threads_, [&](int k) {
            const int row = rows[std::size_t(k)];
            // The row's stored columns (a window of them for the patches of a finer grid).
            const int lo = sums.first_column(row), hi = sums.end_column(row);
            double* nb_row = nb.data() + sums.texel(row, lo) * 3;
            std::fill(nb_row, nb_row + 3 * std::size_t(hi - lo), 0.0);
            // Patches of a finer grid ask for a few texels of a row: only theirs are computed.
            scatter.add_row(row, sums.cmax.data() + std::size_t(row) * std::size_t(sums.classes), sums.classes,
                            nb_row, columns_ ? &(*columns_)[std::size_t(k)] : nullptr, lo);
        });
    }

private:
    LobeSummer summer_;
    int threads_;
    const std::vector<LobeSummer::ColumnRuns>* columns_;
    std::unique_ptr<FourierFirstPass> fourier_;
};

}  // namespace

double cone_cut_cos(double energy, double n) {
    return energy > 0 ? std::pow(std::min(1.0, energy), 1.0 / (n + 1.0)) : 0.0;
}

HdrImage cone_convolve_in_bands(const PreparedLevel& level, const std::vector<BrightTexel>& bright, double n,
                                Size out, const ConeSettings& settings, int threads, const RowProgress& progress,
                                ConeStats* stats, int band_rows) {
    // Each band is a call of its own into the one map: the first pass's sums, the bright terms
    // and the widened texels' sums (24 + 24 + up to 24 bytes a texel, in double) then take memory
    // for one band, not the grid. A lobe one or two texels wide on an 8192x4096 input peaked at
    // 4.1 GB unbanded, 2.2 GB banded (docs/convolution.md). Each band's bounds use its own
    // smallest output (the bright terms' cut, the cap radius), which is what they bound: every
    // texel's error stays within its own share of the tolerance.
    if (band_rows < 1) throw RuntimeError("internal: bands of the cone need at least one row");
    HdrImage result(out.width, out.height, HdrImage::Unwritten{});  // every texel is written by a band
    const TexelSink sink = [&result](int row, int col, const float* rgb) {
        std::copy_n(rgb, 3, result.row(row) + 3 * col);
    };
    ConeStats total;
    // A band is a run of northern rows and their mirrors about the equator, so that the Fourier
    // first pass can sum each row with its mirror (fourier_pass.cpp): half the band's rows from
    // each hemisphere (at least one; the middle row of an odd height is its own mirror).
    const int half = std::max(1, band_rows / 2);
    const int north_end = (out.height + 1) / 2;
    for (int first = 0; first < north_end; first += half) {
        const int last = std::min(north_end, first + half);
        std::vector<int> band;  // ascending
        for (int row = first; row < last; ++row) band.push_back(row);
        for (int row = last - 1; row >= first; --row)
            if (out.height - 1 - row != row) band.push_back(out.height - 1 - row);
        ConeStats part;
        cone_convolve(level, bright, n, out, settings, threads, progress, &part, band, nullptr, nullptr, &sink);
        total.refined_texels += part.refined_texels;
        total.cutoff_energy = part.cutoff_energy;
        total.fourier_first_pass = part.fourier_first_pass;
    }
    if (stats) *stats = total;
    return result;
}

HdrImage cone_convolve(const PreparedLevel& level, const std::vector<BrightTexel>& bright,
                       double n, Size out, const ConeSettings& given_settings, int threads,
                       const RowProgress& progress, ConeStats* stats, const std::vector<int>& only_rows,
                       ConeSumsBackend* backend, const std::vector<LobeSummer::ColumnRuns>* only_columns,
                       const TexelSink* into) {
    // A large grid on the CPU is summed in bands of rows (cone_convolve_in_bands).
    if (only_rows.empty() && !backend && !only_columns && !into &&
        static_cast<long long>(out.width) * out.height > kConeBandTexels)
        return cone_convolve_in_bands(level, bright, n, out, given_settings, threads, progress, stats,
                                      std::max(1, int(kConeBandTexels / out.width)));
    // The output rows computed: all, or only_rows (the others stay 0), and in each the
    // columns of only_columns (or all).
    std::vector<int> rows = only_rows;
    if (rows.empty())
        for (int row = 0; row < out.height; ++row) rows.push_back(row);
    if (only_columns && only_columns->size() != rows.size())
        throw RuntimeError("internal: cone_convolve needs one column list per row");
    const LobeSummer::ColumnRuns whole_row{{0, out.width}};
    const auto columns_of = [&](std::size_t k) -> const LobeSummer::ColumnRuns& {
        return only_columns ? (*only_columns)[k] : whole_row;
    };
    // Whole rows of one column class are summed by the Fourier first pass on the CPU, which
    // costs little more for a wider cone (its rows and columns grow as the square root of
    // log(1 / cut)), while every texel whose bound fails costs a bound query and an annulus: they
    // take a cone that drops far less of the lobe. Decided by the sizes, not the backend, so
    // that the GPU engine sums the same terms.
    // Whole rows only: the patches of a finer grid ask for a few texels of a row.
    const bool fourier =
        !only_columns && FourierFirstPass::used_by_cone(given_settings, level.width(), level.height(), out.width);
    ConeSettings settings = given_settings;
    if (fourier) settings.cutoff_energy = std::min(settings.cutoff_energy, settings.fourier_cutoff_energy);
    std::unique_ptr<CpuConeSums> cpu;
    if (!backend) {
        cpu = std::make_unique<CpuConeSums>(level, out, n, settings, threads, only_columns, fourier);
        backend = cpu.get();
    }
    const auto cut_cos = [n](double energy) { return cone_cut_cos(energy, n); };
    const double c0 = cut_cos(settings.cutoff_energy);
    LobeSums sums = backend->first_pass(rows, c0, progress);

    // Texels stored by the first pass (its rows only when a few were asked for): `widened`
    // and the bright terms share its layout.
    const std::size_t texels = sums.num.size() / 3;
    // Texels whose cut-off bound fails are summed again, with the cone their row
    // needs (wide_cut), into `wide`; `widened` marks them.
    LobeSums wide;
    std::vector<double> wide_cut(std::size_t(out.height), c0);
    std::vector<char> widened(texels, 0);
    // Per (row, class): 1 / D_R and 1 / (D_R + D_out), where D_out is the
    // remainder's lobe weight outside the cone, from the continuous lobe:
    // sum of (cos/cmax)^n dOmega over cos < c is 2pi c^(n+1) / ((n+1) cmax^n).
    struct Denominators {
        std::vector<double> inv, inv_full;
    };
    const auto denominators = [&](const LobeSums& src, const std::vector<double>& cut) {
        Denominators d{std::vector<double>(src.den.size()), std::vector<double>(src.den.size())};
        for (int row = 0; row < out.height; ++row)
            for (int cls = 0; cls < src.classes; ++cls) {
                const std::size_t rc = std::size_t(row) * std::size_t(src.classes) + std::size_t(cls);
                const double c = cut[std::size_t(row)];
                const double den = src.den[rc];
                const double outside =
                    c > 0 ? kTwoPi / (n + 1.0) * std::exp((n + 1.0) * std::log(c) - n * std::log(src.cmax[rc])) : 0.0;
                d.inv[rc] = den > 0 ? 1.0 / den : 0.0;
                d.inv_full[rc] = den > 0 ? 1.0 / (den + outside) : 0.0;
            }
        return d;
    };
    const Denominators narrow_den = denominators(sums, std::vector<double>(std::size_t(out.height), c0));
    Denominators wide_den;
    // E = N_R / D_R + N_B / (D_R + D_out): the remainder outside the cone is
    // taken at the inside's mean (its error is the bound above), while the bright
    // terms, summed over the whole sphere, are divided by the whole lobe weight.
    // The three channel values of output texel (row, col).
    const auto values = [&](int row, int col, const UninitVector<double>& nb, double* v) {
        const std::size_t t = sums.texel(row, col);
        const std::size_t rc = std::size_t(row) * std::size_t(sums.classes) +
                               std::size_t(sums.classes == 1 ? 0 : sums.class_of(col));
        const bool w = widened[t] != 0;
        const LobeSums& src = w ? wide : sums;
        const std::size_t ts = w ? wide.texel(row, col) : t;
        const Denominators& d = w ? wide_den : narrow_den;
        for (std::size_t c = 0; c < 3; ++c)
            v[c] = src.num[3 * ts + c] * d.inv[rc] + (nb.empty() ? 0.0 : nb[3 * t + c] * d.inv_full[rc]);
    };

    // values() for columns [first, last) of `row`, 3 per column into v. A run of one column
    // class with no widened texel is one loop over the stored sums (its texels are consecutive):
    // texel by texel, the index arithmetic and the three branches of values() were most of the
    // three passes over the grid below (9 % of studio's reference-size set).
    // The values are left in `buffer` (resized), and a pointer to them is returned.
    const auto run_values = [&](int row, int first, int last, const UninitVector<double>& nb_now,
                                std::vector<double>& buffer) -> const double* {
        const std::size_t t0 = sums.texel(row, first);
        const std::size_t count = 3 * std::size_t(last - first);
        buffer.resize(count);
        double* v = buffer.data();
        // widened holds 0 or 1: memchr tests many flags at once (the loop here tested one a cycle).
        const bool plain = sums.classes == 1 && std::memchr(widened.data() + t0, 1, count / 3) == nullptr;
        if (!plain) {
            for (int col = first; col < last; ++col) values(row, col, nb_now, v + 3 * std::size_t(col - first));
            return v;
        }
        const double inv = narrow_den.inv[std::size_t(row)], inv_full = narrow_den.inv_full[std::size_t(row)];
        const double* num = sums.num.data() + 3 * t0;
        if (nb_now.empty()) {
            for (std::size_t k = 0; k < count; ++k) v[k] = num[k] * inv + 0.0;
        } else {
            const double* b = nb_now.data() + 3 * t0;
            for (std::size_t k = 0; k < count; ++k) v[k] = num[k] * inv + b[k] * inv_full;
        }
        return v;
    };

    // Smallest positive value over the given output rows (parallel by row).
    const auto smallest_value = [&](const std::vector<int>& over, const UninitVector<double>& nb_now) {
        std::vector<double> row_floor(over.size(), INFINITY);
        parallel_for(int(over.size()), threads, [&](int k) {
            double f = INFINITY;
            std::vector<double> buffer;
            for (const auto& [first, last] : columns_of(std::size_t(k))) {
                const double* v = run_values(over[std::size_t(k)], first, last, nb_now, buffer);
                f = std::min(f, smallest_positive(v, 3 * std::size_t(last - first)));
            }
            row_floor[std::size_t(k)] = f;
        });
        double f = INFINITY;
        for (double v : row_floor) f = std::min(f, v);
        return f;
    };
    // The bright terms (nb stays empty without bright texels; the rows not
    // computed are never read).
    UninitVector<double> nb;
    if (!bright.empty()) {
        const double floor_value = smallest_value(rows, nb);
        const BrightScatter scatter(bright, n, out, std::isfinite(floor_value) ? floor_value : 0.0,
                                    settings.bright_tolerance);
        nb.resize(3 * texels);
        backend->bright(scatter, sums, rows, nb);
    }

    // Widen the cone of the texels whose cut-off bound is not met. Outside the
    // cone but within angle R of a texel, the remainder is at most the cap
    // maximum Lmax(R) (CapMax); beyond R every weight is below (cos R)^n, with R
    // chosen so that all of that is under 0.1 tau_texel of the smallest output.
    // A texel then needs  e max(Lmax(R) - E', E') <= 0.9 tau_texel E'  and
    // gets, with the other failing texels of its row, the cone of the row's
    // smallest such e (only their multiply-adds are done again).
    ConeStats local;
    const double floor_value = smallest_value(rows, nb);
    const double power = level.power();
    double far_cos = 0;  // cos R; 0: the hemisphere
    if (std::isfinite(floor_value) && power > 0 && n > 0) {
        const double w_far = 0.1 * settings.texel_tolerance * floor_value * kTwoPi / ((n + 1.0) * power);
        far_cos = w_far < 1 ? 0.999 * std::pow(w_far, 1.0 / n) : 1.0;
    }
    const double radius = std::acos(std::clamp(far_cos, -1.0, 1.0));
    const CapMax cap_max(level, radius, threads);
    const double global_max = level.max_value();
    std::vector<double> row_need(std::size_t(out.height), settings.cutoff_energy);
    parallel_for(int(rows.size()), threads, [&](int k) {
        const int row = rows[std::size_t(k)];
        const CapMax::Band band = cap_max.band(row_theta(row, out.height));
        const double band_max = cap_max.band_max(band);
        double need_row = settings.cutoff_energy;
        const double target = 0.999 * settings.cutoff_energy;
        const double share = 0.9 * settings.texel_tolerance;
        std::vector<double> buffer;
        for (const auto& [first, last] : columns_of(std::size_t(k))) {
            // Every texel of this run is read before its own flag is set below, and values() reads
            // no other texel's flag: the same values as texel by texel.
            const double* run = run_values(row, first, last, nb, buffer);
            for (int i = first; i < last; ++i) {
                const double* v = run + 3 * std::size_t(i - first);
                // The cut-off fraction this texel allows if the remainder outside the
                // cone is at most lmax: share * E / max(lmax - E, E), least over channels.
                const auto need_for = [&](double lmax) {
                    double need = settings.cutoff_energy;
                    for (int c = 0; c < 3; ++c) {
                        const double e = v[c];
                        const double spread = std::max(lmax - e, e);
                        if (spread > 0 && share * e < need * spread) need = share * e / spread;
                    }
                    return need;
                };
                // The global maximum and the band's maximum are cheap first tests; the
                // cap maximum a tighter one.
                if (need_for(global_max) >= target || need_for(band_max) >= target) continue;
                const double need = need_for(cap_max.query(band, column_phi(i, out.width)));
                if (need < target) {
                    widened[sums.texel(row, i)] = 1;
                    need_row = std::min(need_row, need);
                }
            }
        }
        row_need[std::size_t(row)] = need_row;
    });
    std::vector<int> refine_rows;
    for (int row : rows)
        if (row_need[std::size_t(row)] < settings.cutoff_energy * 0.999) {
            refine_rows.push_back(row);
            wide_cut[std::size_t(row)] = cut_cos(row_need[std::size_t(row)]);
        }
    if (!refine_rows.empty()) {
        std::vector<LobeSummer::ColumnRuns> runs(refine_rows.size());
        std::vector<double> cuts(refine_rows.size());
        for (std::size_t k = 0; k < refine_rows.size(); ++k) {
            const int row = refine_rows[k];
            cuts[k] = wide_cut[std::size_t(row)];
            const int lo = sums.first_column(row), hi = sums.end_column(row);
            const char* flags = widened.data() + sums.texel(row, lo);  // column lo first
            for (int i = lo; i < hi;) {
                if (!flags[i - lo]) {
                    ++i;
                    continue;
                }
                int end = i;
                while (end < hi && flags[end - lo]) ++end;
                runs[k].emplace_back(i, end);
                i = end;
            }
        }
        // Only the annulus between the first cone and the wider one is summed;
        // the first pass's sums complete it.
        wide = backend->annulus(refine_rows, runs, cuts, c0);
        parallel_for(int(refine_rows.size()), threads, [&](int k) {
            const int row = refine_rows[std::size_t(k)];
            for (int cls = 0; cls < wide.classes; ++cls) {
                const std::size_t rc = std::size_t(row) * std::size_t(wide.classes) + std::size_t(cls);
                wide.den[rc] += sums.den[rc];
            }
            for (int col = sums.first_column(row); col < sums.end_column(row); ++col) {
                const std::size_t t = sums.texel(row, col);
                if (!widened[t]) continue;
                const std::size_t tw = wide.texel(row, col);
                for (std::size_t c = 0; c < 3; ++c) wide.num[3 * tw + c] += sums.num[3 * t + c];
            }
        });
        wide_den = denominators(wide, wide_cut);
    }
    for (char f : widened) local.refined_texels += f;
    local.cutoff_energy = settings.cutoff_energy;
    local.fourier_first_pass = cpu && cpu->fourier();
    if (stats) *stats = local;

    // Into a map of the output's size, or texel by texel into `into` (a finer grid's few texels:
    // no map of its size is made).
    HdrImage result = into ? HdrImage() : HdrImage(out.width, out.height);
    parallel_for(int(rows.size()), threads, [&](int k) {
        const int row = rows[std::size_t(k)];
        float* o = into ? nullptr : result.row(row);
        std::vector<double> buffer;
        for (const auto& [first, last] : columns_of(std::size_t(k))) {
            const double* run = run_values(row, first, last, nb, buffer);
            for (int col = first; col < last; ++col) {
                const double* v = run + 3 * std::size_t(col - first);
                const float rgb[3] = {float(std::max(0.0, v[0])), float(std::max(0.0, v[1])), float(std::max(0.0, v[2]))};
                if (into) {
                    (*into)(row, col, rgb);
                } else {
                    // Written out: GCC 12 made std::copy_n of these 12 bytes a call to memmove
                    // per texel (1.3 % of the reference-size set's time).
                    float* dst = o + 3 * col;
                    dst[0] = rgb[0];
                    dst[1] = rgb[1];
                    dst[2] = rgb[2];
                }
            }
        }
    });
    return result;
}

}  // namespace glint::convolution
