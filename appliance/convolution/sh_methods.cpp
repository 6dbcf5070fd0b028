// The SH methods: `sh` (thesis §4.3, with the discrete normalisation below)
// and SH with the bright split (used by `auto`): the remainder of the map (its
// brightest texels taken out) is convolved in the SH domain, the bright texels
// are added exactly, and the truncation is checked for every output texel.
//
// Truncation bound: the dropped bands contribute
//   sum_{l >= L} k_l (2l+1)/(4 pi) sum_k L_k dOmega_k P_l(r.w_k),
// and |P_l| <= 1, so |E - E_L| <= tail(L) * mean_R with
//   tail(L) = sum_{l >= L} |k_l| (2l + 1),   mean_R = sum_k L_k dOmega_k / (4 pi).
// The bright texels carry the map's dynamic range, so mean_R is modest, and a
// texel passes when tail(L) mean_R <= texel_tolerance * E for every channel.
//
// Normalisation: the conventions divide by the discrete lobe weight
// sum_k f_k dOmega_k, SH by the continuous 2 pi / (n+1). Dividing by the SH
// response to the all-ones map under the same quadrature and truncation
// restores the discrete ratio: a constant map gives the constant exactly.
#include <algorithm>
#include <cmath>
#include <numbers>

#include "appliance/convolution/methods.hpp"
#include "appliance/convolution/sh.hpp"
#include "appliance/core/buffer.hpp"
#include "appliance/core/equirect.hpp"
#include "appliance/core/lane_extrema.hpp"
#include "appliance/core/parallel.hpp"

namespace glint::convolution {

std::vector<double> sh_ones_projection(Size input, int order, const ShLegendre& legendre) {
    // Only column m = 0: \bar P_l0 for l < legendre.order() (the recurrence
    // coefficients do not depend on the order, so a longer table serves).
    // Rows j and H-1-j mirror each other (x -> -x, same weight) and
    // \bar P_l0(-x) = (-1)^l \bar P_l0(x): each pair adds 2 w P_l for even l and
    // nothing for odd l, so one recurrence serves both rows.
    const std::size_t table = std::size_t(legendre.order());
    const std::vector<double> w = sh_row_weights(input.width, input.height, ShQuadrature::TexelSolidAngle);
    std::vector<double> c(static_cast<std::size_t>(order), 0.0), p(table);
    for (int j = 0; j < (input.height + 1) / 2; ++j) {
        const bool middle = 2 * j + 1 == input.height;  // the middle row of an odd height has no mirror
        legendre.zonal(std::cos(row_theta(j, input.height)), p.data());
        const double scale = w[std::size_t(j)] * input.width;
        for (int l = 0; l < order; ++l) {
            const double v = scale * p[std::size_t(l)];
            c[std::size_t(l)] += middle ? v : (l % 2 == 0 ? 2.0 * v : 0.0);
        }
    }
    return c;
}

std::vector<double> sh_lobe_normaliser(const std::vector<double>& ones, int order, const std::vector<double>& kernel,
                                       Size out, const ShLegendre& legendre) {
    // The convolution of the all-ones projection, per output row.
    const std::size_t table = std::size_t(legendre.order());
    std::vector<double> p(table);
    std::vector<double> norm(std::size_t(out.height));
    for (int j = 0; j < out.height; ++j) {
        legendre.zonal(std::cos(row_theta(j, out.height)), p.data());
        double e = 0;
        for (int l = 0; l < order; ++l) e += kernel[std::size_t(l)] * ones[std::size_t(l)] * p[std::size_t(l)];
        norm[std::size_t(j)] = e;
    }
    return norm;
}

std::vector<double> sh_truncation_tails(double n, int max_order) {
    // The kernel decays like exp(-l^2 / 2n) (and like l^-2 for n <= 1, whose
    // tail this bound cannot make small); summing 4x past the order, or to
    // where the terms are below 1e-300, covers it.
    const int bands = std::min(kMaxKernelBands, std::max(4 * max_order, max_order + 64));
    const std::vector<double> k = phong_sh_kernel(n, bands);
    std::vector<double> tails(std::size_t(max_order) + 1, 0.0);
    double tail = 0;
    for (int l = bands - 1; l >= 0; --l) {
        tail += std::abs(k[std::size_t(l)]) * (2.0 * l + 1.0);
        if (l <= max_order) tails[std::size_t(l)] = tail;
    }
    return tails;
}

double sh_truncation_tail(double n, int order) { return sh_truncation_tails(n, order)[std::size_t(order)]; }


HdrImage sh_convolve(const ShCoefficients& coefficients, Size input, double n, int order, Size out, int threads,
                     long long* clamped, MethodExecutor* executor) {
    const std::vector<double> kernel = phong_sh_kernel(n, order);
    std::vector<double> e(3 * std::size_t(out.width) * std::size_t(out.height));
    if (executor)
        e = executor->sh_evaluate(coefficients, order, kernel, out);
    else
        sh_evaluate_rows(coefficients, order, kernel, out.width, out.height, threads, [&](int j, const double* row) {
            std::copy(row, row + 3 * std::size_t(out.width), e.data() + 3 * std::size_t(j) * std::size_t(out.width));
        });
    const ShLegendre legendre(order);
    const std::vector<double> norm =
        sh_lobe_normaliser(sh_ones_projection(input, order, legendre), order, kernel, out, legendre);
    HdrImage image(out.width, out.height);
    for (std::size_t v = 0; v < e.size(); ++v) {
        const double x = e[v] / norm[v / (3 * std::size_t(out.width))];
        if (x < 0 && clamped) ++*clamped;
        image.data()[v] = float(std::max(0.0, x));
    }
    return image;
}

namespace {

// Bright texels that share a polar angle (one input row): their basis values differ only in
// cos(m phi) and sin(m phi), so the row's Legendre values are computed once and its texels add
// only their Fourier sums. Indices into the bright texels, by row.
struct BrightRow {
    double x = 0, s = 0;  // cos(theta), sin(theta)
    std::vector<std::size_t> members;
};
std::vector<BrightRow> bright_rows(const std::vector<BrightTexel>& bright) {
    // Keyed by theta itself: directions computed from one theta can differ in their last bits.
    std::vector<std::pair<double, std::size_t>> keyed;
    keyed.reserve(bright.size());
    for (std::size_t t = 0; t < bright.size(); ++t) keyed.push_back({bright[t].theta, t});
    std::sort(keyed.begin(), keyed.end());
    std::vector<BrightRow> rows;
    double theta = NAN;
    for (const auto& [key, t] : keyed) {
        if (rows.empty() || key != theta) {
            theta = key;
            rows.push_back({std::cos(theta), std::abs(std::sin(theta)), {}});
        }
        rows.back().members.push_back(t);
    }
    return rows;
}

// The remainder's first `order` bands plus the bright texels projected as points (each one's
// radiance x solid angle times Y_lm at its direction, as the texel would be in the projection).
// Per row of bright texels: order^2/2 Legendre values and, per texel, 2 x order angle sums,
// instead of order^2 basis values per texel (studio's 1024 bright texels lie on 53 rows).
ShCoefficients with_bright_texels(const ShCoefficients& remainder, const std::vector<BrightTexel>& bright,
                                  const std::vector<BrightRow>& rows, int order, int threads) {
    ShCoefficients c;
    c.order = order;
    const std::size_t values = 3 * std::size_t(order) * std::size_t(order);
    c.rgb.assign(remainder.rgb.begin(), remainder.rgb.begin() + std::ptrdiff_t(values));
    // Fixed chunks of rows summed in order, so the result does not depend on `threads`.
    constexpr std::size_t kChunk = 4;
    const std::size_t chunks = (rows.size() + kChunk - 1) / kChunk;
    std::vector<std::vector<double>> partial(chunks);
    const ShLegendre legendre(order);
    const std::size_t m_values = 3 * std::size_t(order);
    parallel_for(int(chunks), threads, [&](int k) {
        std::vector<double>& sum = partial[std::size_t(k)];
        sum.assign(values, 0.0);
        std::vector<double> p(std::size_t(order) * std::size_t(order + 1) / 2);
        // Per m and channel: sum over the row's texels of E cos(m phi) and E sin(m phi).
        std::vector<double> cos_sums(m_values), sin_sums(m_values);
        // The texels kLanes at a time, each lane's cos(m phi), sin(m phi) by its own rotation and
        // its own sums, added up per m after the row: one texel's recurrence alone waited on its
        // previous step (a complex multiply) at every m.
        constexpr std::size_t kLanes = 8;
        std::vector<double> lane_sums(2 * m_values * kLanes);  // [(m * 3 + channel) * 2 + cos/sin][lane]
        const std::size_t end = std::min(rows.size(), (std::size_t(k) + 1) * kChunk);
        for (std::size_t q = std::size_t(k) * kChunk; q < end; ++q) {
            const BrightRow& row = rows[q];
            std::fill(lane_sums.begin(), lane_sums.end(), 0.0);
            for (std::size_t first = 0; first < row.members.size(); first += kLanes) {
                // Lanes past the row's texels hold a texel of no light.
                // Each lane's rotation starts at cos 0 = 1, sin 0 = 0.
                double r[kLanes] = {}, g[kLanes] = {}, bl[kLanes] = {}, cp[kLanes], sp[kLanes] = {}, cm[kLanes],
                       sm[kLanes] = {};
                for (std::size_t lane = 0; lane < kLanes; ++lane) {
                    cp[lane] = cm[lane] = 1.0;
                    if (first + lane >= row.members.size()) continue;
                    const BrightTexel& b = bright[row.members[first + lane]];
                    // phi = atan2(x, -z), as sh_basis: cos(phi) = -z / sin(theta), sin(phi) = x / sin(theta).
                    const double h = std::hypot(b.x, b.z);
                    cp[lane] = h > 0.0 ? -b.z / h : 1.0;
                    sp[lane] = h > 0.0 ? b.x / h : 0.0;
                    r[lane] = b.r;
                    g[lane] = b.g;
                    bl[lane] = b.b;
                }
                for (int m = 0; m < order; ++m) {
                    double* o = lane_sums.data() + std::size_t(m) * 6 * kLanes;
#pragma omp simd
                    for (std::size_t lane = 0; lane < kLanes; ++lane) {
                        o[0 * kLanes + lane] += r[lane] * cm[lane];
                        o[1 * kLanes + lane] += r[lane] * sm[lane];
                        o[2 * kLanes + lane] += g[lane] * cm[lane];
                        o[3 * kLanes + lane] += g[lane] * sm[lane];
                        o[4 * kLanes + lane] += bl[lane] * cm[lane];
                        o[5 * kLanes + lane] += bl[lane] * sm[lane];
                        const double c_next = cm[lane] * cp[lane] - sm[lane] * sp[lane];
                        sm[lane] = sm[lane] * cp[lane] + cm[lane] * sp[lane];
                        cm[lane] = c_next;
                    }
                }
            }
            for (std::size_t m = 0; m < std::size_t(order); ++m)
                for (std::size_t ch = 0; ch < 3; ++ch) {
                    const double* o = lane_sums.data() + (m * 6 + 2 * ch) * kLanes;
                    double cos_sum = 0, sin_sum = 0;
                    for (std::size_t lane = 0; lane < kLanes; ++lane) {
                        cos_sum += o[lane];
                        sin_sum += o[kLanes + lane];
                    }
                    cos_sums[3 * m + ch] = cos_sum;
                    sin_sums[3 * m + ch] = sin_sum;
                }
            legendre.evaluate(row.x, row.s, p.data());
            for (int m = 0; m < order; ++m) {
                const double* cs = cos_sums.data() + 3 * std::size_t(m);
                const double* ss = sin_sums.data() + 3 * std::size_t(m);
                for (int l = m; l < order; ++l) {
                    const double v = p[std::size_t(legendre_index(l, m))];
                    if (m == 0) {
                        double* o = sum.data() + 3 * std::size_t(l * (l + 1));
                        for (int ch = 0; ch < 3; ++ch) o[ch] += v * cs[ch];
                    } else {
                        const double w = std::numbers::sqrt2 * v;
                        double* oc = sum.data() + 3 * std::size_t(l * (l + 1) + m);
                        double* os = sum.data() + 3 * std::size_t(l * (l + 1) - m);
                        for (int ch = 0; ch < 3; ++ch) {
                            oc[ch] += w * cs[ch];
                            os[ch] += w * ss[ch];
                        }
                    }
                }
            }
        }
    });
    for (const std::vector<double>& sum : partial)
        for (std::size_t v = 0; v < values; ++v) c.rgb[v] += sum[v];
    return c;
}

// The order at which the bright texels are folded into the remainder's SH (0: scattered over the
// grid instead), and the truncation bound of the two together there: see sh_split_convolve.
struct BrightFold {
    int order = 0;
    double bound = 0;
};
BrightFold bright_fold(const std::vector<BrightTexel>& bright, std::size_t rows, double n, int order, int available,
                       double remainder_mean, Size out, double bright_tolerance) {
    if (bright.empty() || !(remainder_mean > 0) || available < order) return {};
    double r = 0, g = 0, b = 0;
    for (const BrightTexel& t : bright) {
        r += t.r;
        g += t.g;
        b += t.b;
    }
    const double bright_mean = std::max({r, g, b}) / (4.0 * kPi);
    // The smallest order whose bound, over remainder and bright texels together, is no looser
    // than the remainder's alone at `order`: every texel that passed its check still passes.
    const std::vector<double> tails = sh_truncation_tails(n, available);
    const double bound = tails[std::size_t(order)] * remainder_mean;
    BrightFold fold;
    for (int l = order; l <= available; ++l)
        if (tails[std::size_t(l)] * (remainder_mean + bright_mean) <= bound) {
            fold = {l, tails[std::size_t(l)] * (remainder_mean + bright_mean)};
            break;
        }
    if (fold.order == 0) return {};
    // Cost: per row of bright texels fold^2 Legendre values and multiply-adds, per bright texel
    // 2 x fold angle sums, and per output row the Legendre sums of the bands added (3 channels),
    // against, per bright texel, a power and a few multiply-adds for each output texel inside its
    // cut-off cone (cos >= (tolerance / K)^(1/n) for K texels of equal peaks; the scatter's cut
    // also scales with the smallest output, which only narrows it). Compared one to one, as
    // measured on studio with the cut of each texel at the tolerance itself (1024 bright
    // texels on 53 rows, sh_split_convolve alone, one thread): folded n = 10 ... 160 at orders
    // 28 ... 82 took 0.55-2.1 ms against 2.8-5.6 ms scattered; at n = 320 (order 119, cost ratio
    // 2.5) 3.6 ms against 2.8, at n = 640 (169, ratio 3.2) 9.0 against 5.7.
    // The scatter's weight threshold for texels of equal peaks: bright_tolerance / K.
    const double cap_share =
        0.5 * (1.0 - std::pow(bright_tolerance / double(bright.size()), 1.0 / std::max(n, 1.0)));
    const double scatter_cost = double(bright.size()) * double(out.width) * double(out.height) * cap_share;
    const double added_bands = double(fold.order) * fold.order - double(order) * order;
    const double L = fold.order;
    const double fold_cost = double(rows) * L * L + 1.5 * double(bright.size()) * L + 3.0 * out.height * added_bands;
    return fold_cost < scatter_cost ? fold : BrightFold{};
}

}  // namespace

ShSplitResult sh_split_convolve(const ShCoefficients& remainder, const std::vector<double>& remainder_ones,
                                const ShLegendre& legendre, double remainder_mean,
                                const std::vector<BrightTexel>& bright_texels, double n, int sh_order,
                                Size out, double texel_tolerance, double bright_tolerance,
                                int threads, MethodExecutor* executor, BrightTerms terms) {
    // Wide lobes on small grids: the bright texels projected into SH with the remainder, at an
    // order where the truncation bound does not grow, instead of their terms scattered over the grid.
    // Not on another device: the GPU evaluates in float, and a sun's energy inside the
    // coefficients would cancel in the dark texels far above the truncation bound.
    const int available = std::min({remainder.order, int(remainder_ones.size()), legendre.order()});
    const bool may_fold = terms != BrightTerms::Scattered && !executor;
    const std::vector<BrightRow> rows = may_fold ? bright_rows(bright_texels) : std::vector<BrightRow>{};
    const BrightFold bright_fold_plan =
        !may_fold
            ? BrightFold{}
            : bright_fold(bright_texels, rows.size(), n, sh_order, available, remainder_mean, out,
                          bright_tolerance);
    const int fold = bright_fold_plan.order;
    const ShCoefficients folded =
        fold > 0 ? with_bright_texels(remainder, bright_texels, rows, fold, threads) : ShCoefficients{};
    const ShCoefficients& coefficients = fold > 0 ? folded : remainder;
    const int order = fold > 0 ? fold : sh_order;
    static const std::vector<BrightTexel> none;
    const std::vector<BrightTexel>& bright = fold > 0 ? none : bright_texels;
    const std::vector<double> kernel = phong_sh_kernel(n, order);
    const std::vector<double> norm = sh_lobe_normaliser(remainder_ones, order, kernel, out, legendre);
    const std::size_t row_values = 3 * std::size_t(out.width);

    // The SH part row by row (every value written), with each row's smallest
    // positive value for the bright terms' cut-off below.
    UninitVector<double> e(row_values * std::size_t(out.height));
    std::vector<double> row_floor(std::size_t(out.height), INFINITY);
    const auto take_row = [&](int j, const double* row) {
        std::copy_n(row, row_values, e.data() + std::size_t(j) * row_values);
        row_floor[std::size_t(j)] = smallest_positive(row, row_values);  // in lanes: see lane_extrema.hpp
    };
    if (executor) {
        const std::vector<double> values = executor->sh_evaluate(coefficients, order, kernel, out);
        for (int j = 0; j < out.height; ++j) take_row(j, values.data() + std::size_t(j) * row_values);
    } else {
        sh_evaluate_rows(coefficients, order, kernel, out.width, out.height, threads, take_row);
    }
    double floor_value = INFINITY;
    for (double f : row_floor) floor_value = std::min(floor_value, f);
    // SH sums are normalised to the continuous lobe, i.e. cmax = 1 (the weights are the lobe's
    // own: the cut needs no allowance for cmax, and cells of bright texels may be merged).
    const BrightScatter scatter(bright, n, out, std::isfinite(floor_value) ? floor_value : 0.0, bright_tolerance,
                                1.0);
    const double one = 1.0;

    const double lobe_den = kTwoPi / (n + 1.0);
    // Folded: the bound of both together (at or below the remainder's alone at sh_order).
    const double error_bound = fold > 0 ? bright_fold_plan.bound : sh_truncation_tail(n, sh_order) * remainder_mean;
    ShSplitResult result;
    result.bright_fold_order = fold;
    result.image = HdrImage(out.width, out.height, HdrImage::Unwritten{});  // every value written below
    float* o = result.image.data().data();
    std::vector<long long> failed(std::size_t(out.height), 0), clamped(std::size_t(out.height), 0);
    parallel_for(out.height, threads, [&](int row) {
        thread_local std::vector<double> nb;
        nb.assign(row_values, 0.0);
        if (!bright.empty()) scatter.add_row(row, &one, 1, nb.data());
        const std::size_t first = std::size_t(row) * row_values;
        const double inv_norm = 1.0 / norm[std::size_t(row)];
        const double* e_row = e.data() + first;
        const double* nb_row = nb.data();
        float* o_row = o + first;
        // Counted without branches into locals: the loop then runs in vector lanes (with a
        // branch and a count in memory per value it ran one value at a time).
        long long row_failed = 0, row_clamped = 0;
        for (std::size_t k = 0; k < row_values; ++k) {
            const double v = (e_row[k] + nb_row[k] / lobe_den) * inv_norm;
            row_failed += !(error_bound <= texel_tolerance * v);
            row_clamped += v < 0;
            o_row[k] = float(std::max(0.0, v));
        }
        failed[std::size_t(row)] = row_failed;
        clamped[std::size_t(row)] = row_clamped;
    });
    for (int row = 0; row < out.height; ++row) {
        result.failed_values += failed[std::size_t(row)];
        result.clamped += clamped[std::size_t(row)];
        if (failed[std::size_t(row)] > 0) result.failed_rows.push_back(row);
    }
    return result;
}

}  // namespace glint::convolution
