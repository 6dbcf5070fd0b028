// The bright-texel split shared by the cone and SH paths: the few brightest
// input texels are taken out of the map and their terms are added exactly, at
// full resolution, to every output texel whose weight for them matters.
#include <algorithm>
#include <bit>
#include <cstdint>
#include <cmath>
#include <cstring>
#include <map>
#include <utility>

#include "appliance/convolution/lobe_sum.hpp"
#include "appliance/convolution/methods.hpp"
#include "appliance/core/equirect.hpp"
#include "appliance/core/lane_extrema.hpp"
#include "appliance/core/parallel.hpp"

namespace glint::convolution {
namespace {

// i modulo m in [0, m), for column indices that may be negative or past the width.
// Indices are almost always within one width of [0, m): those skip the two 64-bit divisions,
// which were a fifth of the bright scatter's own time (two per staged run).
int column_modulo(long long i, int m) {
    if (i >= 0 && i < m) return int(i);
    if (i < 0 && i >= -static_cast<long long>(m)) return int(i + m);
    if (i >= m && i < 2 * static_cast<long long>(m)) return int(i - m);
    return int(((i % m) + m) % m);
}

// The cone's half width as a fraction of the row, for q > -1 (cone_columns_of_half).
double cone_half_turns(double q) { return std::acos(q) / kTwoPi; }

// cone_columns with the half width already known (q > -1), as a fraction of the row: times ow
// here, in the same expressions as before it was cached, so that a compiler contracting them
// into fused multiply-adds does so as it did.
void cone_columns_of_half(double phi_c, double half_turns, int ow, int& first, int& count) {
    const double centre = (phi_c + kPi) / kTwoPi * ow - 0.5;  // output column units
    const double half = half_turns * ow;
    first = int(std::floor(centre - half)) - 1;  // one column of margin: weights decide
    count = std::min(ow, int(std::ceil(centre + half)) + 1 - first + 1);
}

// The columns [first, first + count) (unwrapped, one column of margin each side) of a row of
// `ow` columns where cos(phi - phi_c) >= q, around azimuth phi_c; q <= -1: the whole row.
void cone_columns(double phi_c, double q, int ow, int& first, int& count) {
    if (q <= -1.0) {
        first = 0;
        count = ow;
        return;
    }
    cone_columns_of_half(phi_c, cone_half_turns(q), ow, first, count);
}

}  // namespace

namespace {

// split_bright's work: `source` (when not null) is copied into remainder, row j by the thread
// that sums row j first.
BrightSplit split_bright_into(HdrImage remainder, const HdrImage* source, double contrast, int max_count,
                              int threads) {
    // The remainder is the map itself with its bright texels zeroed.
    BrightSplit split;
    split.remainder = std::move(remainder);
    const HdrImage& input = split.remainder;
    const int w = input.width();
    const int h = input.height();
    const std::vector<double> omega = row_solid_angles(w, h);
    struct Candidate {
        float value;
        int i, j;
    };
    // Per row: the largest channel's power, and (in a second pass, once the
    // threshold is known) the texels above it; rows in parallel, merged in order.
    // The row's largest value too (in cache with the sum): a row whose largest is under the
    // threshold holds no candidate, and most rows are passed over in the second pass.
    std::vector<double> row_power(std::size_t(h), 0.0);
    std::vector<float> row_max(std::size_t(h), 0.0f);
    parallel_for(h, threads, [&](int j) {
        if (source) std::copy_n(source->row(j), 3 * std::size_t(w), split.remainder.row(j));
        row_power[std::size_t(j)] = max_channel_row_sum(input.row(j), w) * omega[std::size_t(j)];
        row_max[std::size_t(j)] = largest_or_zero(input.row(j), 3 * std::size_t(w));
    });
    double power = 0;
    for (double p : row_power) power += p;
    const double mean = power / (4.0 * kPi);

    split.threshold = contrast * mean;
    split.remainder_power = power;
    std::vector<std::vector<Candidate>> row_candidates(static_cast<std::size_t>(h));
    parallel_for(h, threads, [&](int j) {
        const float* row = input.row(j);
        if (!(mean > 0) || max_count <= 0) return;
        // No texel's largest channel exceeds the row's largest (NaN is never a candidate).
        if (double(row_max[std::size_t(j)]) <= split.threshold) return;
        for (int i = 0; i < w; ++i) {
            const float v = std::max({row[3 * i], row[3 * i + 1], row[3 * i + 2]});
            if (double(v) > split.threshold) row_candidates[std::size_t(j)].push_back({v, i, j});
        }
    });
    if (!(mean > 0) || max_count <= 0) return split;
    std::vector<Candidate> candidates;
    for (const auto& rc : row_candidates) candidates.insert(candidates.end(), rc.begin(), rc.end());
    std::sort(candidates.begin(), candidates.end(), [](const Candidate& a, const Candidate& b) {
        return a.value > b.value || (a.value == b.value && (a.j < b.j || (a.j == b.j && a.i < b.i)));
    });
    if (int(candidates.size()) > max_count) candidates.resize(std::size_t(max_count));
    for (const Candidate& c : candidates) {
        const Rgb l = input.at(c.i, c.j);
        const double om = omega[std::size_t(c.j)];
        const double theta = row_theta(c.j, h);
        const double phi = column_phi(c.i, w);
        const glm::dvec3 d = direction_from_angles(theta, phi);
        split.texels.push_back({d.x, d.y, d.z, theta, phi, l.r * om, l.g * om, l.b * om});
        split.remainder.set(c.i, c.j, {0, 0, 0});
    }
    // The rows that lost texels summed again; the total in the same order as max_channel_power.
    std::vector<char> changed(std::size_t(h), 0);
    for (const Candidate& c : candidates) changed[std::size_t(c.j)] = 1;
    split.remainder_power = 0;
    for (int j = 0; j < h; ++j) {
        if (changed[std::size_t(j)])
            row_power[std::size_t(j)] = max_channel_row_sum(input.row(j), w) * omega[std::size_t(j)];
        split.remainder_power += row_power[std::size_t(j)];
    }
    return split;
}

}  // namespace

BrightSplit split_bright(HdrImage&& input, double contrast, int max_count, int threads) {
    return split_bright_into(std::move(input), nullptr, contrast, max_count, threads);
}

BrightSplit split_bright(const HdrImage& input, double contrast, int max_count, int threads) {
    if (input.empty()) return split_bright_into(HdrImage(), nullptr, contrast, max_count, threads);
    return split_bright_into(HdrImage(input.width(), input.height(), HdrImage::Unwritten{}), &input, contrast,
                             max_count, threads);
}

namespace {

// Bright-cell merging (merge_bright_cells). Cells are those of equirect grids kCellRows x
// 2 kCellRows, halved kCellLevels times: level L has kCellRows << L rows. A texel's cell at
// every level is a prefix of its Morton key at the finest level, so after one sort every cell
// is a contiguous range.
constexpr int kCoarsestCellRows = 8;
constexpr int kCellLevels = 14;  // finest: 65536 rows, finer than any input's texels
constexpr std::size_t kMinTexelsToMerge = 256;
constexpr double kWidestMergedCell = 0.5;  // radians from a cell's centre to its farthest member

std::uint64_t cell_key(double theta, double phi) {
    const std::uint64_t rows = std::uint64_t(kCoarsestCellRows) << (kCellLevels - 1);
    // Clamped as doubles first: a conversion of an out-of-range double to an integer is undefined.
    const double row = std::clamp(theta / kPi * double(rows), 0.0, double(rows - 1));
    const double column = std::clamp((phi + kPi) / kTwoPi * double(2 * rows), 0.0, double(2 * rows - 1));
    const std::uint64_t r = std::isfinite(row) ? std::uint64_t(row) : 0;
    const std::uint64_t c = std::isfinite(column) ? std::uint64_t(column) : 0;
    // The column's top bit (the grid is twice as wide as tall) first, then row and column bits
    // interleaved from the top, so that a cell of level L is the key's top 1 + 3 + 3 + 2 L bits.
    const int bits = std::countr_zero(rows);  // row bits
    std::uint64_t key = c >> bits;
    for (int b = bits - 1; b >= 0; --b) key = (key << 2) | (((r >> b) & 1u) << 1) | ((c >> b) & 1u);
    return key;
}

// The key bits below a level's cell.
int cell_shift(int level) { return 2 * (kCellLevels - 1 - level); }

}  // namespace

std::vector<BrightTexel> merge_bright_cells(const std::vector<BrightTexel>& bright, double n, double relative,
                                            double absolute) {
    if (bright.size() < kMinTexelsToMerge || !(n >= 2) || !std::isfinite(n) || !(relative > 0) ||
        !(absolute >= 0))
        return bright;
    double peaks = 0;
    for (const BrightTexel& t : bright) peaks += std::max({t.r, t.g, t.b});
    if (!(peaks > 0)) return bright;
    const double eta = absolute / peaks;  // the absolute allowance per unit of a cell's energy
    // Tables over the angle alpha from a merged term's direction, in steps h fine enough for the
    // lobe: cos^(n-2), cos^(n-1), cos^n (0 from pi/2 on) and sin (1 from pi/2 on).
    const double h = std::min(0.01, 0.03 / std::sqrt(n));
    const int steps = int(std::ceil((kPi / 2 + kWidestMergedCell) / h)) + 3;
    // Filled on first use (made up to index `through`): a cell's bound is settled within a few
    // lobe widths, so at n = 5120 the ~4900 steps to the horizon (a pow each, 0.4 ms) were
    // mostly never read.
    std::vector<double> p2(std::size_t(steps) + 1), p1(p2.size()), pn(p2.size()), sn(p2.size());
    std::size_t tabled = 0;
    const auto table_through = [&](std::size_t through) {
        if (through < tabled) return;
        const std::size_t end = std::min(p2.size(), std::max(through + 1, 2 * tabled + 64));
        for (std::size_t j = tabled; j < end; ++j) {
            const double a = double(j) * h;
            const double c = a < kPi / 2 ? std::cos(a) : 0.0;
            p2[j] = c > 0 ? std::pow(c, n - 2) : 0.0;
            p1[j] = p2[j] * c;
            pn[j] = p1[j] * c;
            sn[j] = a < kPi / 2 ? std::sin(a) : 1.0;
        }
        tabled = end;
    };

    std::vector<std::pair<std::uint64_t, std::size_t>> order(bright.size());
    for (std::size_t k = 0; k < bright.size(); ++k) order[k] = {cell_key(bright[k].theta, bright[k].phi), k};
    std::sort(order.begin(), order.end());

    std::vector<BrightTexel> merged;
    merged.reserve(bright.size());
    // Whether the members order[a, b) may stand as one term; if so, that term in `out`. With
    // channel -1 the term holds all three channels, in the direction of the members' mean
    // weighted by their channels' sum (a cell whose colour changes errs to first order); with a
    // channel, that channel alone, in its own mean direction (no first-order error).
    const auto try_merge = [&](std::size_t a, std::size_t b, int channel, BrightTexel& out) {
        const auto weight_of = [&](const BrightTexel& t) {
            return channel < 0 ? t.r + t.g + t.b : channel == 0 ? t.r : channel == 1 ? t.g : t.b;
        };
        glm::dvec3 sum(0.0);
        double weight = 0;
        for (std::size_t m = a; m < b; ++m) {
            const BrightTexel& t = bright[order[m].second];
            if (!(t.r >= 0 && t.g >= 0 && t.b >= 0)) return false;
            sum += weight_of(t) * glm::dvec3(t.x, t.y, t.z);
            weight += weight_of(t);
        }
        if (channel >= 0 && weight == 0) {  // every member dark in this channel: no term
            out = BrightTexel{};
            return true;
        }
        if (!(weight > 0)) return false;
        const glm::dvec3 centre = sum / weight;
        const double mu = glm::length(centre);
        if (!(mu > 0.5)) return false;
        const glm::dvec3 axis = centre / mu;
        // A tangent basis at the axis, for the members' spread across it.
        const glm::dvec3 e1 = glm::normalize(std::abs(axis.y) < 0.9 ? glm::cross(axis, glm::dvec3(0, 1, 0))
                                                                   : glm::cross(axis, glm::dvec3(1, 0, 0)));
        const glm::dvec3 e2 = glm::cross(axis, e1);
        // Per channel: the energy E, the first moment's offset from E * centre (radial and
        // tangential), the energy-weighted squares of |cos beta - mu| and its products with
        // sin beta, and the tangential parts' second moments (whose largest eigenvalue bounds
        // the energy-weighted square of e.t for any unit tangent e).
        double energy[3] = {0, 0, 0}, saa[3] = {0, 0, 0}, sab[3] = {0, 0, 0}, suu[3] = {0, 0, 0},
               sww[3] = {0, 0, 0}, suw[3] = {0, 0, 0};
        glm::dvec3 moment[3] = {glm::dvec3(0.0), glm::dvec3(0.0), glm::dvec3(0.0)};
        double widest_sin = 0, narrowest_cos = 1;  // over the members, for the radius
        for (std::size_t m = a; m < b; ++m) {
            const BrightTexel& t = bright[order[m].second];
            const glm::dvec3 d(t.x, t.y, t.z);
            const double cb = glm::dot(axis, d);
            const glm::dvec3 tangent = d - cb * axis;
            const double sb = glm::length(tangent);
            const double u = glm::dot(tangent, e1), w = glm::dot(tangent, e2);
            widest_sin = std::max(widest_sin, sb);
            narrowest_cos = std::min(narrowest_cos, cb);
            const double da = std::abs(cb - mu);
            const double l[3] = {t.r, t.g, t.b};
            for (int ch = 0; ch < 3; ++ch) {
                if (channel >= 0 && ch != channel) continue;
                energy[ch] += l[ch];
                moment[ch] += l[ch] * d;
                saa[ch] += l[ch] * da * da;
                sab[ch] += l[ch] * da * sb;
                suu[ch] += l[ch] * u * u;
                sww[ch] += l[ch] * w * w;
                suw[ch] += l[ch] * u * w;
            }
        }
        // At least every member's angle from the axis (one atan2 for the cell, not per member).
        const double radius = narrowest_cos > 0 ? std::atan2(widest_sin, narrowest_cos) : kPi;
        if (!(radius <= kWidestMergedCell)) return false;
        // The worst channel's coefficients, per unit of its energy.
        double vr = 0, vt = 0, caa = 0, cab = 0, cbb = 0;
        for (int ch = 0; ch < 3; ++ch) {
            if (!(energy[ch] > 0)) continue;  // all members 0 in this channel: no error
            const glm::dvec3 v = (moment[ch] - energy[ch] * centre) / energy[ch];
            const double radial = glm::dot(v, axis);
            vr = std::max(vr, std::abs(radial));
            vt = std::max(vt, glm::length(v - radial * axis));
            const double aa = saa[ch] / energy[ch];
            const double half_sum = 0.5 * (suu[ch] + sww[ch]) / energy[ch];
            const double half_diff = 0.5 * (suu[ch] - sww[ch]) / energy[ch];
            const double bb = half_sum + std::hypot(half_diff, suw[ch] / energy[ch]);
            caa = std::max(caa, aa);
            cab = std::max(cab, std::min(sab[ch] / energy[ch], std::sqrt(aa * bb)));  // Cauchy-Schwarz
            cbb = std::max(cbb, bb);
        }
        const double mun = std::pow(mu, n), mun1 = std::pow(mu, n - 1);
        out = BrightTexel{};
        out.x = axis.x;
        out.y = axis.y;
        out.z = axis.z;
        out.theta = std::acos(std::clamp(axis.y, -1.0, 1.0));
        out.phi = std::atan2(axis.x, -axis.z);
        out.r = energy[0] * mun;
        out.g = energy[1] * mun;
        out.b = energy[2] * mun;
        const int shift = int(std::ceil(radius / h));
        for (int j = 0; j + 1 < steps; ++j) {
            // Over alpha in [j h, (j + 1) h]: the largest cosine any member or the centre can
            // have, the largest sine, and the smallest merged term.
            const int i = std::max(0, j - shift);
            if (double(i) * h >= kPi / 2) return true;  // every member behind: both sides 0
            table_through(std::size_t(j) + 1);
            const double s = sn[std::size_t(j) + 1];
            // g'(r.m) at r.m = mu cos(alpha) <= mu cos(j h): the first-order term is at the centre.
            const double first = mun1 * p1[std::size_t(j)] * (vr + s * vt);
            const double second = 0.5 * (n - 1) * p2[std::size_t(i)] * (caa + 2 * s * cab + s * s * cbb);
            if (n * (first + second) > relative * mun * pn[std::size_t(j) + 1] + eta) return false;
            // From here on the bound only falls: done once its largest value is within eta.
            if (n * (p1[std::size_t(i)] * (vr + vt) + 0.5 * (n - 1) * p2[std::size_t(i)] * (caa + 2 * cab + cbb)) <= eta)
                return true;
        }
        return false;  // not reached: the tables run past every member's horizon
    };
    // Cells from the coarsest level tried down: a cell that passes is one term, one that does not is
    // split into its cells of the next level; a lone texel (or one at the finest level) as is.
    // A failed cell still to be split: its members order[a, b), and its level (its cells are
    // of level + 1).
    struct Span {
        std::size_t a, b;
        int level;
    };
    // Cells wider than 4 lobe widths are not tried: a cell whose members spread across it is far
    // outside the bound, and a tight group inside one is found in the finer cells anyway.
    int first_level = 0;
    while (first_level + 1 < kCellLevels && kPi / double(kCoarsestCellRows << first_level) > 4.0 / std::sqrt(n))
        ++first_level;
    std::vector<Span> unsplit{{0, order.size(), first_level - 1}};
    while (!unsplit.empty()) {
        const Span s = unsplit.back();
        unsplit.pop_back();
        for (std::size_t a = s.a; a < s.b;) {
            const int level = s.level + 1;
            const std::uint64_t cell = order[a].first >> cell_shift(level);
            std::size_t b = a + 1;
            while (b < s.b && (order[b].first >> cell_shift(level)) == cell) ++b;
            BrightTexel t, per_channel[3];
            if (b - a == 1) {
                merged.push_back(bright[order[a].second]);
            } else if (try_merge(a, b, -1, t)) {
                merged.push_back(t);
            } else if (b - a > 3 && try_merge(a, b, 0, per_channel[0]) && try_merge(a, b, 1, per_channel[1]) &&
                       try_merge(a, b, 2, per_channel[2])) {
                for (const BrightTexel& c : per_channel)
                    if (std::max({c.r, c.g, c.b}) > 0) merged.push_back(c);
            } else if (level + 1 < kCellLevels) {
                unsplit.push_back({a, b, level});
            } else {
                for (std::size_t m = a; m < b; ++m) merged.push_back(bright[order[m].second]);
            }
            a = b;
        }
    }
    return merged;
}

BrightScatter::BrightScatter(const std::vector<BrightTexel>& input, double n, Size out, double floor_value,
                             double tolerance, double cmax_floor, bool float_sums)
    // Merged cells may err by half the tolerance of their own terms plus half the tolerance of
    // floor_value (in weight units: times lobe_den). The weights are the lobe's own over the
    // sums' scale, (r.w / cmax)^n, unclamped: the bound holds for them as for max(0, r.w)^n, and
    // the error's scale cmax^-n cancels against the normalisation's. (With the old clamp,
    // min(1, r.w / cmax)^n, it did not: a 16x16 cell of 8K texels at n = 40-160 erred 1.4-1.5x
    // its allowance near the clamp, and the cone merged nothing.)
    : bright_(merge_bright_cells(input, n, 0.5 * tolerance,
                                 0.5 * tolerance * std::max(0.0, floor_value) * kTwoPi / (n + 1.0))),
      n_(n),
      ratio_cap_(n > 0 ? std::exp(80.0 / n) : 1.0),
      out_(out),
      float_sums_(float_sums) {
    const std::vector<BrightTexel>& bright = bright_;
    // A bright term may be dropped where it is below its texel's share of the budget times the
    // smallest output (and so of every output), the shares being the texels' peaks over the
    // peaks' sum: the dropped terms together then stay below budget x floor_value at every output
    // texel, however many bright texels there are (a cut per texel alone let a compact lamp of K
    // texels drop K times it just outside their cut cones). As a weight ratio that is one
    // threshold for every texel, then a cosine. The budget is `tolerance` from kFullBudgetTexels
    // texels up and shrinks with fewer, so that a lone sun is cut at tolerance /
    // kFullBudgetTexels, not at the whole budget. cmax_floor allows for cmax < 1 on coarse grids
    // (the weight is (r.w / cmax)^n).
    constexpr double kFullBudgetTexels = 1000;
    const double lobe_den = kTwoPi / (n + 1.0);  // sum of weights, continuous, cmax ~ 1
    double peaks = 0;
    for (const BrightTexel& t : bright) peaks += std::max({t.r, t.g, t.b});
    const double budget = tolerance * std::min(1.0, double(bright.size()) / kFullBudgetTexels);
    const double ratio = peaks > 0 ? budget * floor_value * lobe_den / peaks : 2.0;
    min_cos_.resize(bright.size());
    sin_theta_.resize(bright.size());
    first_row_.resize(bright.size());
    last_row_.resize(bright.size());
    for (std::size_t k = 0; k < bright.size(); ++k) {
        min_cos_[k] = n == 0 ? 0.0 : (ratio >= 1.0 ? 2.0 : cmax_floor * std::pow(ratio, 1.0 / n));
        sin_theta_[k] = std::sin(bright[k].theta);
        cos_phi_b_.push_back(std::cos(bright[k].phi));
        sin_phi_b_.push_back(std::sin(bright[k].phi));
        // Rows with |theta_r - theta_b| <= acos(min_cos) (below, cos(theta_r - theta_b) >= min_cos).
        if (min_cos_[k] > 1.0) {
            first_row_[k] = 0;
            last_row_[k] = -1;
        } else if (min_cos_[k] <= -1.0) {
            first_row_[k] = 0;
            last_row_[k] = out.height - 1;
        } else {
            const double reach = std::acos(min_cos_[k]);
            const double rows_per_radian = out.height / kPi;
            first_row_[k] = std::max(0, int(std::floor((bright[k].theta - reach) * rows_per_radian - 0.5)) - 1);
            last_row_[k] = std::min(out.height - 1, int(std::ceil((bright[k].theta + reach) * rows_per_radian - 0.5)) + 1);
        }
    }
    // Groups: texels of one polar angle whose centres sit at the same phase between output
    // columns (a bright region of an input whose width divides the output's, row by row).
    std::map<std::pair<double, long long>, std::size_t> group_of;
    const bool fractional = n > 0.0 && n < 2.0 && n != 1.0;
    const bool clustered = n == 1.0 || n == 0.0 || fractional;
    for (std::size_t k = 0; k < bright.size() && !clustered; ++k) {  // n < 2 uses the clusters below
        if (first_row_[k] > last_row_[k]) continue;
        const double centre = (bright[k].phi + kPi) / kTwoPi * out.width - 0.5;
        const double whole = std::floor(centre + 1e-10);
        const auto key = std::make_pair(bright[k].theta, std::llround((centre - whole) * 1e9));
        const auto [it, added] = group_of.emplace(key, groups_.size());
        if (added) groups_.push_back({{}, {}, first_row_[k], last_row_[k]});
        Group& g = groups_[it->second];
        g.members.push_back(k);
        g.shift.push_back(int(whole));
        g.first_row = std::min(g.first_row, first_row_[k]);
        g.last_row = std::max(g.last_row, last_row_[k]);
    }
    // For n = 1 (irradiance), clusters of bright texels within cells of kClusterCell radians:
    // where a whole cluster is in front and below cmax, its members' terms are one dot product
    // (add_linear_row). The cell balances a cluster's own cost (a pass over the columns where it
    // is linear) against its members' terms left in the band around its horizon and peak, whose
    // width grows with the cell: about 3 degrees for texels packed at 1024x512's spacing.
    // For n = 0 every member in front weighs 1, so a cluster wholly in front adds its energy: the
    // 16384 bright texels of a 4096x2048 photograph took 0.43 s added one by one over a
    // hemisphere (2026-12-07).
    // For 0 < n < 2 other than 1 (no cells are merged below n = 2), a cluster wholly well in front
    // is a Taylor series of its members' sum about its centre's cosine x_c (add_linear_row):
    //   sum L (x_c + delta)^n = E x_c^n + n x_c^(n-1) m.w + n (n-1) / 2 x_c^(n-2) w^T M w
    //                           + n (n-1) (n-2) / 6 x_c^(n-3) T[w, w, w] + R,
    // with m, M and T the members' first, second and third moments about the centre (|delta| <=
    // radius r). |R| <= |n (n-1) (n-2) (n-3)| / 24 (x_c - r)^(n-4) r^4 E, under kTaylorRelative of
    // the members' sum where r / x_c <= kappa, kappa / (1 - kappa) = (kTaylorRelative / C)^(1/4):
    // there, and elsewhere member by member. (The third-order term halves the band of members
    // against a second-order series: kappa 0.13 against 0.066 at n = 0.1.) Smaller cells than for n = 1 keep the band of members narrow:
    // the 4096x2048 photograph's 16384 bright texels took 0.06-0.08 s a map one by one.
    if (fractional) {
        constexpr double kTaylorRelative = 1e-5;
        const double C = std::abs(n * (n - 1) * (n - 2) * (n - 3)) / 24;
        const double t = std::pow(kTaylorRelative / C, 0.25);
        taylor_kappa_ = t / (1 + t);
    }
    if (clustered) {
        const double kClusterCell = fractional ? 0.02 : 0.05;
        std::map<std::pair<int, int>, std::size_t> cluster_of;
        for (std::size_t k = 0; k < bright.size(); ++k) {
            if (first_row_[k] > last_row_[k]) continue;
            const int band = int(std::floor(bright[k].theta / kClusterCell));
            const double mid = (band + 0.5) * kClusterCell;
            const int cells = std::max(1, int(std::floor(kTwoPi * std::sin(std::min(mid, kPi - 1e-9)) / kClusterCell)));
            const int cell = std::min(cells - 1, int(std::floor((bright[k].phi + kPi) / kTwoPi * cells)));
            const auto [it, added] = cluster_of.emplace(std::make_pair(band, cell), clusters_.size());
            if (added) clusters_.push_back(Cluster{});
            Cluster& c = clusters_[it->second];
            if (added) {
                c.first_row = first_row_[k];
                c.last_row = last_row_[k];
            }
            c.members.push_back(k);
            c.first_row = std::min(c.first_row, first_row_[k]);
            c.last_row = std::max(c.last_row, last_row_[k]);
        }
        for (Cluster& c : clusters_) {
            glm::dvec3 sum(0.0);
            for (const std::size_t k : c.members) sum += glm::dvec3(bright[k].x, bright[k].y, bright[k].z);
            const glm::dvec3 centre = glm::normalize(sum);
            c.cos_theta = std::clamp(centre.y, -1.0, 1.0);
            c.sin_theta = std::sqrt(std::max(0.0, 1.0 - c.cos_theta * c.cos_theta));
            c.phi = std::atan2(centre.x, -centre.z);
            for (const std::size_t k : c.members) {
                const BrightTexel& b = bright[k];
                // The angle to the centre from the chord (accurate for small angles, unlike acos).
                const double chord = glm::length(glm::dvec3(b.x, b.y, b.z) - centre);
                c.radius = std::max(c.radius, 2.0 * std::asin(std::min(1.0, chord / 2.0)));
                // Sums of L dOmega times the direction's parts as stage_weights writes the cosine.
                const double st_b = std::sin(b.theta), u = st_b * std::cos(b.phi), v = st_b * std::sin(b.phi),
                             w = std::cos(b.theta);
                const double l[3] = {b.r, b.g, b.b};
                for (int ch = 0; ch < 3; ++ch) {
                    c.u[ch] += u * l[ch];
                    c.v[ch] += v * l[ch];
                    c.w[ch] += w * l[ch];
                    c.e[ch] += l[ch];
                    c.ml[ch].push_back(l[ch]);
                }
                c.mu.push_back(u);
                c.mv.push_back(v);
                c.mw.push_back(w);
                c.cut.push_back(std::max(min_cos_[k], 1e-300));  // a term needs cosine > 0 too
            }
            while (c.mu.size() % Cluster::kMemberLanes != 0) {  // no weight: cosine 0 < cut 2
                c.mu.push_back(0.0);
                c.mv.push_back(0.0);
                c.mw.push_back(0.0);
                c.cut.push_back(2.0);
                for (auto& l : c.ml) l.push_back(0.0);
            }
            c.radius = c.radius * (1.0 + 1e-9) + 1e-9;  // rounding of the centre and the chords
            // The centre in the members' (u, v, w) and their moments about it (fractional n).
            c.centre[0] = c.sin_theta * std::cos(c.phi);
            c.centre[1] = c.sin_theta * std::sin(c.phi);
            c.centre[2] = c.cos_theta;
            for (std::size_t m = 0; m < c.members.size(); ++m) {
                const double d[3] = {c.mu[m] - c.centre[0], c.mv[m] - c.centre[1], c.mw[m] - c.centre[2]};
                for (int ch = 0; ch < 3; ++ch) {
                    const double l = c.ml[ch][m];
                    for (int a = 0; a < 3; ++a) c.m1[ch][a] += l * d[a];
                    c.m2[ch][0] += l * d[0] * d[0];
                    c.m2[ch][1] += l * d[0] * d[1];
                    c.m2[ch][2] += l * d[0] * d[2];
                    c.m2[ch][3] += l * d[1] * d[1];
                    c.m2[ch][4] += l * d[1] * d[2];
                    c.m2[ch][5] += l * d[2] * d[2];
                    // uuu uuv uuw uvv uvw uww vvv vvw vww www
                    double* t3 = c.m3[ch];
                    t3[0] += l * d[0] * d[0] * d[0];
                    t3[1] += l * d[0] * d[0] * d[1];
                    t3[2] += l * d[0] * d[0] * d[2];
                    t3[3] += l * d[0] * d[1] * d[1];
                    t3[4] += l * d[0] * d[1] * d[2];
                    t3[5] += l * d[0] * d[2] * d[2];
                    t3[6] += l * d[1] * d[1] * d[1];
                    t3[7] += l * d[1] * d[1] * d[2];
                    t3[8] += l * d[1] * d[2] * d[2];
                    t3[9] += l * d[2] * d[2] * d[2];
                }
            }
            c.taylor_cos = taylor_kappa_ > 0 ? c.radius / taylor_kappa_ : 2.0;
            // The cone that holds every member's cut-off cone.
            const double widest = std::acos(std::clamp(*std::min_element(c.cut.begin(), c.cut.end()), -1.0, 1.0));
            c.reach_cos = widest + c.radius >= kPi ? -2.0 : std::cos(widest + c.radius);
        }
    }
    cos_phi_.resize(std::size_t(out.width));
    sin_phi_.resize(std::size_t(out.width));
    for (int i = 0; i < out.width; ++i) {
        cos_phi_[std::size_t(i)] = std::cos(column_phi(i, out.width));
        sin_phi_[std::size_t(i)] = std::sin(column_phi(i, out.width));
    }
}

std::vector<char> BrightScatter::rows_reached() const {
    // +1 where a texel's rows start, -1 past their end; the running sum counts the texels.
    std::vector<int> starts(std::size_t(out_.height) + 1, 0);
    for (std::size_t k = 0; k < bright_.size(); ++k) {
        if (first_row_[k] > last_row_[k]) continue;
        ++starts[std::size_t(first_row_[k])];
        --starts[std::size_t(last_row_[k]) + 1];
    }
    std::vector<char> reached(std::size_t(out_.height), 0);
    int count = 0;
    for (int j = 0; j < out_.height; ++j) {
        count += starts[std::size_t(j)];
        reached[std::size_t(j)] = count > 0;
    }
    return reached;
}

namespace {

// One plane per channel of a row's bright terms (BrightScatter::add_row), in T.
template <typename T>
struct TermPlanes {
    std::vector<T> planes;
    int width = 0;
    void resize(int w) {
        width = w;
        planes.resize(3 * std::size_t(w));
    }
    void zero(int lo, int hi) {
        for (int c = 0; c < 3; ++c) std::fill(planes.begin() + c * width + lo, planes.begin() + c * width + hi, T(0));
    }
    // A run of weights w on columns [first, first + count), times the texel's channels.
    void add(const T* __restrict w, int first, int count, const BrightTexel& b) {
        T* __restrict pr = planes.data() + first;
        T* __restrict pg = pr + width;
        T* __restrict pb = pg + width;
        const T br = T(b.r), bg = T(b.g), bb = T(b.b);
        for (int t = 0; t < count; ++t) {
            pr[t] += w[t] * br;
            pg[t] += w[t] * bg;
            pb[t] += w[t] * bb;
        }
    }
    // Columns [lo, hi) added into an interleaved row that starts at column first_column.
    void into(double* row, int first_column, int lo, int hi) const {
        const T* pr = planes.data();
        const T* pg = pr + width;
        const T* pb = pg + width;
        for (int i = lo; i < hi; ++i) {
            double* o = row + 3 * std::size_t(i - first_column);
            o[0] += double(pr[i]);
            o[1] += double(pg[i]);
            o[2] += double(pb[i]);
        }
    }
};

}  // namespace

void BrightScatter::add_row(int row, const double* cmax_row, int classes, double* nb_row,
                            const LobeSummer::ColumnRuns* columns, int first_column) const {
    const int ow = out_.width;
    const double theta_r = row_theta(row, out_.height);
    const double ct = std::cos(theta_r);
    const double st = std::sin(theta_r);
    // The row's runs (one per bright texel and reach, often a few dozen columns) are staged
    // into one buffer of weights and raised to the power n together, kBatch at a time: one
    // call per batch instead of one per run, with no short vector tails. The texels of a group
    // (same polar angle, same phase of their centre between output columns) have the same
    // weights shifted by whole columns: the weights are staged once for the group's widest
    // reach, and each texel's runs read them at its own shift.
    constexpr std::size_t kBatch = 4096;
    thread_local std::vector<double> weights;
    thread_local std::vector<Staged> staged;
    thread_local std::vector<Reach> reach;
    // The terms are summed into one plane per channel over the row's physical columns, not into
    // nb_row's interleaved texels: the three multiply-adds of a weight then read and write whole
    // vectors (interleaved, the loop spent most of its time permuting lanes: 42 % of a 4096x2048
    // photograph's whole set, 2026-12-07). The planes are zeroed only over the hull of the
    // columns reached [hull_lo, hull_hi), and added into nb_row at the end, so each texel sums
    // the same terms in the same order as before. With float_sums_ the planes and the weights
    // (after the power, in double) are floats: twice the lanes and half the bytes stored.
    thread_local TermPlanes<double> wide;
    thread_local TermPlanes<float> narrow;
    thread_local std::vector<float> weights32;
    // The planes of this scatter's type, for f(planes).
    const auto on_planes = [&](const auto& f) {
        if (float_sums_)
            f(narrow);
        else
            f(wide);
    };
    weights.resize(kBatch + std::size_t(ow));
    on_planes([&](auto& p) { p.resize(ow); });
    int hull_lo = 0, hull_hi = 0;
    const auto zero_columns = [&](int lo, int hi) { on_planes([&](auto& p) { p.zero(lo, hi); }); };
    const auto reach_columns = [&](int lo, int hi) {
        if (hull_lo >= hull_hi) {
            zero_columns(lo, hi);
            hull_lo = lo;
            hull_hi = hi;
            return;
        }
        if (lo < hull_lo) zero_columns(lo, hull_lo), hull_lo = lo;
        if (hi > hull_hi) zero_columns(hull_hi, hi), hull_hi = hi;
    };
    staged.clear();
    std::size_t filled = 0;
    const auto flush = [&] {
        raise_to_power(weights.data(), int(filled), n_);
        if (float_sums_) {
            weights32.resize(filled);
            for (std::size_t k = 0; k < filled; ++k) weights32[k] = float(weights[k]);
        }
        for (const Staged& r : staged) {
            reach_columns(r.first, r.first + r.count);
            if (float_sums_)
                narrow.add(weights32.data() + r.offset, r.first, r.count, bright_[r.texel]);
            else
                wide.add(weights.data() + r.offset, r.first, r.count, bright_[r.texel]);
        }
        staged.clear();
        filled = 0;
    };
    // The planes' columns [lo, hi) into nb_row.
    const auto add_planes = [&](int lo, int hi) { on_planes([&](const auto& p) { p.into(nb_row, first_column, lo, hi); }); };
    // One member's physical run [lo, hi), whose weights start at position pos of a staged span
    // (positions past the end of a whole-row span continue at its start).
    const auto read_run = [&](std::size_t k, int lo, int hi, int pos, int span, std::size_t base) {
        const int len = hi - lo;
        const int head = std::min(len, span - pos);
        staged.push_back({k, lo, head, base + std::size_t(pos)});
        if (head < len) staged.push_back({k, lo + head, len - head, base});
    };
    // The members reach[a, b) share their reference's weights (reach[a]'s texel): staged once
    // over the union of their reaches, seen from the reference.
    const auto stage_shared = [&](std::size_t a, std::size_t b, double sa, double bq) {
        const Reach& ref = reach[a];
        long long u0 = ref.first, u1 = ref.first + ref.count;
        for (std::size_t m = a + 1; m < b; ++m) {
            const long long f = reach[m].first - (reach[m].shift - ref.shift);
            u0 = std::min(u0, f);
            u1 = std::max(u1, f + reach[m].count);
        }
        const int span = int(std::min<long long>(u1 - u0, ow));
        const int start = column_modulo(u0, ow);
        const std::size_t base = filled;
        // The span's physical columns, at most two runs, into consecutive positions.
        const int head = std::min(span, ow - start);
        stage_weights(ref.texel, start, start + head, sa, bq, cmax_row, classes, weights.data() + filled);
        if (head < span) stage_weights(ref.texel, 0, span - head, sa, bq, cmax_row, classes,
                                       weights.data() + filled + std::size_t(head));
        filled += std::size_t(span);
        for (std::size_t m = a; m < b; ++m) {
            const Reach& r = reach[m];
            // Physical column p of this member reads the reference's weight at p - (shift offset).
            const int offset = r.shift - ref.shift;
            const int first = column_modulo(r.first, ow);
            const int runs[2][2] = {{first, std::min(ow, first + r.count)}, {0, std::max(0, first + r.count - ow)}};
            for (const auto& run : runs) {
                if (run[1] <= run[0]) continue;
                const auto pos = [&](int lo) { return column_modulo(lo - offset - u0, ow); };
                if (!columns) {
                    read_run(r.texel, run[0], run[1], pos(run[0]), span, base);
                    continue;
                }
                // Only the asked columns (patches of a finer grid: a few texels of a wide row).
                for (const auto& [first_col, last_col] : *columns) {
                    const int lo = std::max(first_col, run[0]), hi = std::min(last_col, run[1]);
                    if (lo < hi) read_run(r.texel, lo, hi, pos(lo), span, base);
                }
            }
        }
        if (filled >= kBatch) flush();
    };
    // Bright texel k's columns on this row, [first, first + count) unwrapped, or false when its
    // cut-off cone misses the row (sa = sin theta_r sin theta_b, bq = cos theta_r cos theta_b).
    // A group's members share their polar angle and (one cut for every texel) their cut-off,
    // so q and its acos are the same for all of them: remembered from the last member.
    double last_q = 3.0, last_half = 0.0;
    const auto member_reach = [&](std::size_t k, double sa, double bq, int& first, int& count) {
        if (row < first_row_[k] || row > last_row_[k]) return false;
        const double c_b = min_cos_[k];
        // cos(theta_r - theta_b) < c_b: no column of this row reaches.
        if (bq + sa < c_b) return false;
        const double q = sa > 1e-300 ? (c_b - bq) / sa : (bq >= c_b ? -2.0 : 2.0);
        if (q > 1.0) return false;
        if (q <= -1.0) {
            cone_columns(bright_[k].phi, q, ow, first, count);  // the whole row
        } else {
            if (q != last_q) {
                last_q = q;
                last_half = cone_half_turns(q);
            }
            cone_columns_of_half(bright_[k].phi, last_half, ow, first, count);
        }
        return true;
    };
    // With `columns`: a reach [first, first + count) (unwrapped) cut to the hull of its asked
    // columns, so that only those weights are staged (a few tiles of a fine grid under a wide
    // lobe); false when it asks for none.
    const auto clip_to_columns = [&](int& first, int& count) {
        const int f = column_modulo(first, ow);
        int lo = count, hi = -1;  // offsets within the reach
        // The runs meeting physical columns [a, b) (ascending: found by bisection, as a row of a
        // fine grid may hold dozens of tiles' runs), their overlap as offsets from `base`.
        const auto meet = [&](int a, int b, int base) {
            auto it = std::upper_bound(columns->begin(), columns->end(), a,
                                       [](int x, const std::pair<int, int>& run) { return x < run.second; });
            for (; it != columns->end() && it->first < b; ++it) {
                lo = std::min(lo, std::max(it->first, a) - base);
                hi = std::max(hi, std::min(it->second, b) - base);
            }
        };
        meet(f, std::min(f + count, ow), f);
        if (f + count > ow) meet(0, f + count - ow, f - ow);  // the part past the seam
        if (hi <= lo) return false;
        first += lo;
        count = hi - lo;
        return true;
    };
    if (!clusters_.empty()) {
        add_linear_row(row, ct, st, cmax_row, classes, nb_row, columns, first_column);
        return;
    }
    for (const Group& g : groups_) {
        if (row < g.first_row || row > g.last_row) continue;
        const BrightTexel& lead = bright_[g.members.front()];
        const double sa = st * sin_theta_[g.members.front()];
        const double bq = ct * lead.y;  // lead.y = cos(theta_b), the group's
        reach.clear();
        for (std::size_t m = 0; m < g.members.size(); ++m) {
            const std::size_t k = g.members[m];
            int first = 0, count = 0;
            if (member_reach(k, sa, bq, first, count) && (!columns || clip_to_columns(first, count)))
                reach.push_back({k, first, count, g.shift[m]});
        }
        if (reach.empty()) continue;
        // Columns of one class share cmax: members share weights only with a shift of whole
        // classes (always, for one class).
        if (classes > 1)
            std::stable_sort(reach.begin(), reach.end(), [&](const Reach& x, const Reach& y) {
                return column_modulo(x.shift, classes) < column_modulo(y.shift, classes);
            });
        for (std::size_t a = 0; a < reach.size();) {
            std::size_t b = a + 1;
            while (b < reach.size() && (classes == 1 || column_modulo(reach[b].shift, classes) == column_modulo(reach[a].shift, classes)))
                ++b;
            stage_shared(a, b, sa, bq);
            a = b;
        }
    }
    if (filled > 0) flush();
    if (hull_lo >= hull_hi) return;
    if (!columns) {
        add_planes(hull_lo, hull_hi);
        return;
    }
    // Only the asked columns: the hull's others may lie outside the caller's window.
    for (const auto& [first_col, last_col] : *columns)
        add_planes(std::max(first_col, hull_lo), std::min(last_col, hull_hi));
}

void BrightScatter::add_linear_row(int row, double ct, double st, const double* cmax_row, int classes,
                                   double* nb_row, const LobeSummer::ColumnRuns* columns, int first_column) const {
    const int ow = out_.width;
    const double cap = ratio_cap_;
    const bool step = n_ == 0.0;
    const bool fractional = !step && n_ != 1.0;
    const double n = n_;
    // cmax^-n per class (the weights are (cosine / cmax)^n).
    thread_local std::vector<double> cm_pow;
    if (fractional) {
        cm_pow.resize(std::size_t(classes));
        for (int k = 0; k < classes; ++k) cm_pow[std::size_t(k)] = std::pow(cmax_row[k], -n);
    }
    // A run of physical columns [lo, hi) cut to the asked ones (all, without `columns`).
    const auto for_asked = [&](int lo, int hi, const auto& f) {
        if (!columns) {
            f(lo, hi);
            return;
        }
        for (const auto& [first_col, last_col] : *columns) {
            const int a = std::max(first_col, lo), b = std::min(last_col, hi);
            if (a < b) f(a, b);
        }
    };
    thread_local std::vector<std::pair<int, int>> linear;  // physical runs, ascending
    thread_local std::vector<std::pair<int, int>> pieces;
    // n = 1: each cluster's linear part over its columns, gathered over the clusters and added
    // after them (below): per column the clusters' (u, v, w) sums make one dot product,
    // instead of one per cluster with three divisions by cmax each (half of add_linear_row's
    // time on studio's irradiance map).
    struct LinearRun {
        int lo, hi;
        const Cluster* cluster;
    };
    thread_local std::vector<LinearRun> linear_runs;
    linear_runs.clear();
    for (const Cluster& c : clusters_) {
        if (row < c.first_row || row > c.last_row) continue;
        // The columns where every member is in front (angle to the centre <= pi/2 - radius):
        // there each weight is cosine / cmax (unclamped, and far below ratio_cap_ for n = 1), and
        // the members' sum is the dot product of the texel's direction with their
        // radiance-weighted directions. As column ranges around the centre's column cc:
        // |i - cc| <= h_hi, the ends then settled column by column (below).
        linear.clear();
        const double ac = st * c.sin_theta, bc = ct * c.cos_theta;
        // The cosine of the angle from output column i of this row to the centre.
        const auto centre_cos = [&](long long unwrapped) {
            const std::size_t i = std::size_t(column_modulo(unwrapped, ow));
            return st * (cos_phi_[i] * c.centre[0] + sin_phi_[i] * c.centre[1]) + ct * c.centre[2];
        };
        // The run [lo, hi] (inclusive, unwrapped, shorter than the row, holding every column
        // whose centre_cos is at least `limit`, which form one arc) cut to those columns: a
        // column of margin from acos costs every member's term at a 64-128 column grid's
        // 3-6 degree columns (8.7 band columns per cluster and row on studio's irradiance map,
        // margins included).
        const auto settle = [&](long long& lo, long long& hi, double limit) {
            while (lo <= hi && centre_cos(lo) < limit) ++lo;
            while (hi >= lo && centre_cos(hi) < limit) --hi;
        };
        // Fractional n: where the centre's cosine is at least taylor_cos (the Taylor series).
        if (c.radius < kPi / 2 && (!fractional || c.taylor_cos < 1.0)) {
            const double s_out = fractional ? c.taylor_cos : std::sin(c.radius);
            double q_out;  // linear where q_out <= cos(dphi)
            if (ac > 1e-300)
                q_out = (s_out - bc) / ac;
            else
                q_out = bc >= s_out ? -2.0 : 2.0;
            if (q_out <= -1.0) {
                linear.emplace_back(0, ow);  // the whole row
            } else if (q_out <= 1.0) {
                const double cc = (c.phi + kPi) / kTwoPi * ow - 0.5;
                const double h_hi = std::min(std::acos(q_out) / kTwoPi * ow, ow / 2.0 - 1.0);
                // Inclusive, unwrapped: a column of margin at each end, then settled where the
                // run is shorter than the row (else the margins stand inside it).
                long long lo = std::llround(std::ceil(cc - h_hi)) - 1, hi = std::llround(std::floor(cc + h_hi)) + 1;
                if (hi - lo + 1 < ow) {
                    settle(lo, hi, s_out);
                } else {
                    lo += 2;
                    hi -= 2;
                }
                if (hi >= lo) {
                    const int start = column_modulo(lo, ow);
                    const int end = start + int(hi - lo + 1);
                    linear.emplace_back(start, std::min(end, ow));
                    if (end > ow) linear.emplace_back(0, end - ow);
                }
                std::sort(linear.begin(), linear.end());
            }
        }
        for (const auto& [lo, hi] : linear)
            for_asked(lo, hi, [&](int a, int b) {
                if (step) {  // n = 0: every member in front weighs 1
                    for (int i = a; i < b; ++i) {
                        double* o = nb_row + 3 * std::size_t(i - first_column);
                        for (int ch = 0; ch < 3; ++ch) o[ch] += c.e[ch];
                    }
                    return;
                }
                if (fractional) {  // the Taylor series about the centre's cosine
                    for (int i = a; i < b; ++i) {
                        const double u = st * cos_phi_[std::size_t(i)], v = st * sin_phi_[std::size_t(i)], w = ct;
                        const double x = u * c.centre[0] + v * c.centre[1] + w * c.centre[2];
                        const double p0 = std::pow(x, n) * cm_pow[std::size_t(classes == 1 ? 0 : i % classes)];
                        const double p1 = n * p0 / x, p2 = 0.5 * (n - 1) * p1 / x, p3 = (n - 2) / 3 * p2 / x;
                        const double uu = u * u, uv = 2 * u * v, uw = 2 * u * w, vv = v * v, vw = 2 * v * w, ww = w * w;
                        // The third moments' weights: each product of w's parts times its count.
                        const double w3[10] = {u * u * u,     3 * u * u * v, 3 * u * u * w, 3 * u * v * v, 6 * u * v * w,
                                               3 * u * w * w, v * v * v,     3 * v * v * w, 3 * v * w * w, w * w * w};
                        double* o = nb_row + 3 * std::size_t(i - first_column);
                        for (int ch = 0; ch < 3; ++ch) {
                            const double* m1 = c.m1[ch];
                            const double* m2 = c.m2[ch];
                            const double* m3 = c.m3[ch];
                            double third = 0;
                            for (int k = 0; k < 10; ++k) third += w3[k] * m3[k];
                            o[ch] += p0 * c.e[ch] + p1 * (u * m1[0] + v * m1[1] + w * m1[2]) +
                                     p2 * (uu * m2[0] + uv * m2[1] + uw * m2[2] + vv * m2[3] + vw * m2[4] + ww * m2[5]) +
                                     p3 * third;
                        }
                    }
                    return;
                }
                linear_runs.push_back({a, b, &c});
            });
        // Elsewhere in the cluster's reach (the band around its horizon), each member's own term,
        // with its own cut, texel by texel.
        const double cq = ac > 1e-300 ? (c.reach_cos - bc) / ac : (bc >= c.reach_cos ? -2.0 : 2.0);
        if (cq > 1.0) continue;
        int first = 0, count = ow;
        cone_columns(c.phi, cq, ow, first, count);
        if (count < ow) {  // its margins settled too: no member reaches past reach_cos
            long long lo = first, hi = (long long)first + count - 1;
            settle(lo, hi, c.reach_cos);
            if (hi < lo) continue;
            first = int(lo);
            count = int(hi - lo + 1);
        }
        first = column_modulo(first, ow);
        const int runs[2][2] = {{first, std::min(ow, first + count)}, {0, std::max(0, first + count - ow)}};
        const std::size_t padded = c.mu.size();  // members and their padding, whole vectors
        for (const auto& run : runs) {
            if (run[1] <= run[0]) continue;
            pieces.clear();
            int cur = run[0];
            for (const auto& [lo, hi] : linear) {
                if (hi <= cur || lo >= run[1]) continue;
                if (lo > cur) pieces.emplace_back(cur, lo);
                cur = std::max(cur, hi);
            }
            if (cur < run[1]) pieces.emplace_back(cur, run[1]);
            for (const auto& [lo, hi] : pieces)
                for_asked(lo, hi, [&](int a, int b) {
                    // Members in vector lanes (the scalar loop's branch kept it scalar: 48 % of a
                    // studio irradiance map's time); each lane's sums in the members' order.
                    using Lanes = double __attribute__((vector_size(Cluster::kMemberLanes * sizeof(double))));
                    const auto load = [](const double* p) {
                        Lanes v;
                        std::memcpy(&v, p, sizeof v);
                        return v;
                    };
                    for (int i = a; i < b; ++i) {
                        const double cm = cmax_row[classes == 1 ? 0 : i % classes];
                        const double x = st * cos_phi_[std::size_t(i)], y = st * sin_phi_[std::size_t(i)];
                        Lanes sum[3] = {};
                        for (std::size_t m = 0; m < padded; m += Cluster::kMemberLanes) {
                            const Lanes cosine = x * load(c.mu.data() + m) + y * load(c.mv.data() + m) +
                                                 ct * load(c.mw.data() + m);
                            const Lanes q = step ? Lanes{} + 1.0 : cosine / cm;
                            Lanes w = cosine >= load(c.cut.data() + m) ? (q < cap ? q : cap) : Lanes{};
                            if (fractional)  // q^n lane by lane (no vector pow); 0 stays 0
                                for (std::size_t lane = 0; lane < Cluster::kMemberLanes; ++lane)
                                    if (w[lane] > 0) w[lane] = std::pow(w[lane], n);
                            for (int ch = 0; ch < 3; ++ch) sum[ch] += w * load(c.ml[ch].data() + m);
                        }
                        double* o = nb_row + 3 * std::size_t(i - first_column);
                        for (int ch = 0; ch < 3; ++ch)
                            for (std::size_t lane = 0; lane < Cluster::kMemberLanes; ++lane) o[ch] += sum[ch][lane];
                    }
                });
        }
    }
    if (linear_runs.empty()) return;
    // The row cut where any run starts or ends; in each segment the runs that cover it (kept as
    // a list while sweeping the cuts, so that the many short runs of asked columns cost no more
    // than their count) summed once, then one dot product per column.
    thread_local std::vector<int> cuts;
    cuts.clear();
    for (const LinearRun& r : linear_runs) {
        cuts.push_back(r.lo);
        cuts.push_back(r.hi);
    }
    std::sort(cuts.begin(), cuts.end());
    cuts.erase(std::unique(cuts.begin(), cuts.end()), cuts.end());
    std::stable_sort(linear_runs.begin(), linear_runs.end(),
                     [](const LinearRun& x, const LinearRun& y) { return x.lo < y.lo; });
    thread_local std::vector<const LinearRun*> active;
    active.clear();
    std::size_t next_run = 0;
    for (std::size_t k = 0; k + 1 < cuts.size(); ++k) {
        const int a = cuts[k], b = cuts[k + 1];
        std::erase_if(active, [a](const LinearRun* r) { return r->hi <= a; });
        while (next_run < linear_runs.size() && linear_runs[next_run].lo <= a) active.push_back(&linear_runs[next_run++]);
        if (active.empty()) continue;
        double su[3] = {0, 0, 0}, sv[3] = {0, 0, 0}, sw[3] = {0, 0, 0};
        for (const LinearRun* r : active)
            for (int ch = 0; ch < 3; ++ch) {
                su[ch] += r->cluster->u[ch];
                sv[ch] += r->cluster->v[ch];
                sw[ch] += r->cluster->w[ch];
            }
        for (int i = a; i < b; ++i) {
            const double inv_cm = 1.0 / cmax_row[classes == 1 ? 0 : i % classes];
            const double u = st * cos_phi_[std::size_t(i)] * inv_cm, v = st * sin_phi_[std::size_t(i)] * inv_cm,
                         w = ct * inv_cm;
            double* o = nb_row + 3 * std::size_t(i - first_column);
            for (int ch = 0; ch < 3; ++ch) o[ch] += u * su[ch] + v * sv[ch] + w * sw[ch];
        }
    }
}

void BrightScatter::stage_weights(std::size_t k, int i0, int end, double a, double bq, const double* cmax_row,
                                  int classes, double* w) const {
    const double cpb = cos_phi_b_[k], spb = sin_phi_b_[k];
    const int len = end - i0;
    // Weights relative to each texel's cmax, as in the lobe sums, unclamped (up to ratio_cap_,
    // whose power is e^80). One class (add_bright_lobes, and grids whose columns are all alike)
    // has one cmax for the row: no per-column index, so the loop vectorises.
    const double* cp = cos_phi_.data() + i0;
    const double* sp = sin_phi_.data() + i0;
    const double cap = ratio_cap_;
    if (classes == 1) {
        const double cm = cmax_row[0];
        for (int t = 0; t < len; ++t) {
            const double cosine = a * (cp[t] * cpb + sp[t] * spb) + bq;
            w[t] = cosine > 0 ? std::min(cap, cosine / cm) : 0.0;
        }
    } else {
        for (int t = 0; t < len; ++t) {
            const double cosine = a * (cp[t] * cpb + sp[t] * spb) + bq;
            w[t] = cosine > 0 ? std::min(cap, cosine / cmax_row[(i0 + t) % classes]) : 0.0;
        }
    }
}

}  // namespace glint::convolution
