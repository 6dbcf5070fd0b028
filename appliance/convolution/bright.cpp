// The bright-texel split shared by the cone and SH paths: the few brightest
// input texels are taken out of the map and their terms are added exactly, at
// full resolution, to every output texel whose weight for them matters.
#include <algorithm>
#include <cmath>

#include "appliance/convolution/lobe_sum.hpp"
#include "appliance/convolution/methods.hpp"
#include "appliance/core/equirect.hpp"
#include "appliance/core/parallel.hpp"

namespace glint::convolution {

BrightSplit split_bright(HdrImage image, double contrast, int max_count, int threads) {
    // The remainder is the map itself with its bright texels zeroed: no copy when the caller
    // hands the map over.
    BrightSplit split;
    split.remainder = std::move(image);
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
    std::vector<double> row_power(std::size_t(h), 0.0);
    parallel_for(h, threads, [&](int j) {
        row_power[std::size_t(j)] = max_channel_row_sum(input.row(j), w) * omega[std::size_t(j)];
    });
    double power = 0;
    for (double p : row_power) power += p;
    const double mean = power / (4.0 * kPi);

    split.threshold = contrast * mean;
    std::vector<std::vector<Candidate>> row_candidates(static_cast<std::size_t>(h));
    parallel_for(h, threads, [&](int j) {
        const float* row = input.row(j);
        if (!(mean > 0) || max_count <= 0) return;
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
    return split;
}

BrightScatter::BrightScatter(const std::vector<BrightTexel>& bright, double n, Size out, double floor_value,
                             double tolerance, double cmax_floor)
    : bright_(bright), n_(n), out_(out) {
    // A bright term below `tolerance` of the smallest output (and so of every
    // output) may be dropped: as a weight ratio, then as a cosine. cmax_floor
    // allows for cmax < 1 on coarse grids (the weight is (r.w / cmax)^n).
    const double lobe_den = kTwoPi / (n + 1.0);  // sum of weights, continuous, cmax ~ 1
    min_cos_.resize(bright.size());
    sin_theta_.resize(bright.size());
    first_row_.resize(bright.size());
    last_row_.resize(bright.size());
    for (std::size_t k = 0; k < bright.size(); ++k) {
        const double peak = std::max({bright[k].r, bright[k].g, bright[k].b});
        const double ratio = tolerance * floor_value * lobe_den / peak;
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
    cos_phi_.resize(std::size_t(out.width));
    sin_phi_.resize(std::size_t(out.width));
    for (int i = 0; i < out.width; ++i) {
        cos_phi_[std::size_t(i)] = std::cos(column_phi(i, out.width));
        sin_phi_[std::size_t(i)] = std::sin(column_phi(i, out.width));
    }
}

bool BrightScatter::may_reach_row(int row) const {
    for (std::size_t k = 0; k < bright_.size(); ++k)
        if (row >= first_row_[k] && row <= last_row_[k]) return true;
    return false;
}

void BrightScatter::add_row(int row, const double* cmax_row, int classes, double* nb_row,
                            const LobeSummer::ColumnRuns* columns, int first_column) const {
    const int ow = out_.width;
    const double theta_r = row_theta(row, out_.height);
    const double ct = std::cos(theta_r);
    const double st = std::sin(theta_r);
    // The row's runs (one per bright texel and reach, often a few dozen columns) are staged
    // into one buffer of weights and raised to the power n together, kBatch at a time: one
    // call per batch instead of one per run, with no short vector tails. The products and the
    // order of the sums are those of one run at a time.
    constexpr std::size_t kBatch = 4096;
    thread_local std::vector<double> weights;
    thread_local std::vector<Staged> staged;
    weights.resize(kBatch + std::size_t(ow));
    staged.clear();
    std::size_t filled = 0;
    const auto flush = [&] {
        raise_to_power(weights.data(), int(filled), n_);
        for (const Staged& r : staged) {
            const BrightTexel& b = bright_[r.texel];
            const double* w = weights.data() + r.offset;
            double* o = nb_row + 3 * std::size_t(r.first - first_column);
            for (int t = 0; t < r.count; ++t) {
                o[3 * t] += w[t] * b.r;
                o[3 * t + 1] += w[t] * b.g;
                o[3 * t + 2] += w[t] * b.b;
            }
        }
        staged.clear();
        filled = 0;
    };
    const auto stage = [&](std::size_t k, int i0, int end, double a, double bq) {
        stage_weights(k, i0, end, a, bq, cmax_row, classes, weights.data() + filled);
        staged.push_back({k, i0, end - i0, filled});
        filled += std::size_t(end - i0);
        if (filled >= kBatch) flush();
    };
    for (std::size_t k = 0; k < bright_.size(); ++k) {
        const BrightTexel& b = bright_[k];
        if (row < first_row_[k] || row > last_row_[k]) continue;
        const double c_b = min_cos_[k];
        // cos(theta_r - theta_b) < c_b: no column of this row reaches.
        if (ct * b.y + st * sin_theta_[k] < c_b) continue;
        const double a = st * sin_theta_[k];
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
        // The columns as at most two runs inside [0, ow) (the range may wrap).
        first = ((first % ow) + ow) % ow;
        const int runs[2][2] = {{first, std::min(ow, first + count)}, {0, std::max(0, first + count - ow)}};
        for (const auto& reach : runs) {
            if (reach[1] <= reach[0]) continue;
            if (!columns) {
                stage(k, reach[0], reach[1], a, bq);
                continue;
            }
            // Only the asked columns (patches of a finer grid: a few texels of a wide row).
            for (const auto& [first_col, last_col] : *columns) {
                const int lo = std::max(first_col, reach[0]), hi = std::min(last_col, reach[1]);
                if (lo < hi) stage(k, lo, hi, a, bq);
            }
        }
    }
    if (filled > 0) flush();
}

void BrightScatter::stage_weights(std::size_t k, int i0, int end, double a, double bq, const double* cmax_row,
                                  int classes, double* w) const {
    const double cpb = cos_phi_b_[k], spb = sin_phi_b_[k];
    const int len = end - i0;
    // Weights relative to each texel's cmax, as in the lobe sums. One class (add_bright_lobes, and
    // grids whose columns are all alike) has one cmax for the row: no per-column index, so the
    // loop vectorises.
    const double* cp = cos_phi_.data() + i0;
    const double* sp = sin_phi_.data() + i0;
    if (classes == 1) {
        const double cm = cmax_row[0];
        for (int t = 0; t < len; ++t) {
            const double cosine = a * (cp[t] * cpb + sp[t] * spb) + bq;
            w[t] = cosine > 0 ? std::min(1.0, cosine / cm) : 0.0;
        }
    } else {
        for (int t = 0; t < len; ++t) {
            const double cosine = a * (cp[t] * cpb + sp[t] * spb) + bq;
            w[t] = cosine > 0 ? std::min(1.0, cosine / cmax_row[(i0 + t) % classes]) : 0.0;
        }
    }
}

}  // namespace glint::convolution
