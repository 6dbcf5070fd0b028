// Row-pair kernel for the Phong lobe sums (see lobe_sum.hpp for the derivation).
#include "appliance/convolution/lobe_sum.hpp"
#include "appliance/core/errors.hpp"

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstring>
#include <numeric>
#include <string>

#include "appliance/core/equirect.hpp"
#include "appliance/core/lane_extrema.hpp"
#include "appliance/core/parallel.hpp"

namespace glint::convolution {
namespace {

// exp(x) is below the smallest normal double (2.2e-308) for x < -708.39.
constexpr double kLogSmallestNormal = -708.39;

}  // namespace

double max_channel_row_sum(const float* rgb, int width) {
    // Eight partial sums, texel i + k in lane k: one chain of dependent double additions would
    // cost its latency (~4 cycles) per texel. Eight texels are 24 floats, loaded as three
    // vectors and shuffled into their red, green and blue (the compiler does not vectorise
    // loads three apart by itself).
    using Floats = float __attribute__((vector_size(8 * sizeof(float))));
    using Doubles = double __attribute__((vector_size(8 * sizeof(double))));
    constexpr int kLanes = 8;
    Doubles lanes = {};
    int i = 0;
    for (; i + kLanes <= width; i += kLanes) {
        Floats a, b, c;
        const float* t = rgb + 3 * i;
        std::memcpy(&a, t, sizeof a);
        std::memcpy(&b, t + 8, sizeof b);
        std::memcpy(&c, t + 16, sizeof c);
        // From a and b the first texels' channels, then the last ones' from c (indices of the
        // second operand count from 8).
        const Floats r = __builtin_shufflevector(__builtin_shufflevector(a, b, 0, 3, 6, 9, 12, 15, 0, 0), c,
                                                 0, 1, 2, 3, 4, 5, 10, 13);
        const Floats g = __builtin_shufflevector(__builtin_shufflevector(a, b, 1, 4, 7, 10, 13, 0, 0, 0), c,
                                                 0, 1, 2, 3, 4, 8, 11, 14);
        const Floats bl = __builtin_shufflevector(__builtin_shufflevector(a, b, 2, 5, 8, 11, 14, 0, 0, 0), c,
                                                  0, 1, 2, 3, 4, 9, 12, 15);
        // std::max(std::max(r, g), b) lane by lane: (x < y) ? y : x.
        const Floats rg = r < g ? g : r;
        const Floats m = rg < bl ? bl : rg;
        lanes += __builtin_convertvector(m, Doubles);
    }
    double lane[kLanes];
    std::memcpy(lane, &lanes, sizeof lane);
    for (; i < width; ++i) lane[0] += double(std::max(std::max(rgb[3 * i], rgb[3 * i + 1]), rgb[3 * i + 2]));
    return ((lane[0] + lane[1]) + (lane[2] + lane[3])) + ((lane[4] + lane[5]) + (lane[6] + lane[7]));
}

double max_channel_power(const HdrImage& image) {
    double power = 0;
    for (int j = 0; j < image.height(); ++j)
        power += max_channel_row_sum(image.row(j), image.width()) * row_solid_angle(j, image.width(), image.height());
    return power;
}

PreparedLevel::PreparedLevel(const HdrImage& level, int threads)
    : width_(level.width()), height_(level.height()), threads_(threads) {
    cos_t_.resize(std::size_t(height_));
    sin_t_.resize(std::size_t(height_));
    omega_ = row_solid_angles(width_, height_);
    planes_.resize(std::size_t(height_) * 3 * std::size_t(width_));
    std::vector<float> row_max(std::size_t(height_), 0.0f);
    std::vector<double> row_power(std::size_t(height_), 0.0);
    parallel_for(height_, threads_, [&](int j) {
        const double t = row_theta(j, height_);
        cos_t_[std::size_t(j)] = std::cos(t);
        sin_t_[std::size_t(j)] = std::sin(t);
        const float* src = level.row(j);
        float* r = planes_.data() + std::size_t(j) * 3 * std::size_t(width_);
        float* g = r + width_;
        float* b = g + width_;
        for (int i = 0; i < width_; ++i) {
            r[i] = src[3 * i];
            g[i] = src[3 * i + 1];
            b[i] = src[3 * i + 2];
        }
        // Apart from the copy, in lanes: one chain of maxima was 70 % of this loop in `perf`.
        // Every value counts on its own. (The former per-texel std::max({r, g, b}) dropped a
        // texel's green and blue when its red was NaN; a loaded EXR has no NaN, exr_io.cpp.)
        row_max[std::size_t(j)] = largest_or_zero(src, 3 * std::size_t(width_));
        row_power[std::size_t(j)] = max_channel_row_sum(src, width_) * omega_[std::size_t(j)];
    });
    for (int j = 0; j < height_; ++j) {
        max_value_ = std::max(max_value_, row_max[std::size_t(j)]);
        power_ += row_power[std::size_t(j)];
    }
}

LobeSummer::Geometry LobeSummer::make_geometry(const PreparedLevel& level, const std::vector<char>& rows) const {
    Geometry g;
    g.level = &level;
    g.width = level.width();
    const int w = g.width;
    g.step = w / std::gcd(w, out_w_);
    g.base.resize(std::size_t(classes_));
    g.frac.resize(std::size_t(classes_));
    for (int p = 0; p < classes_; ++p) {
        // Output column centre in level column units (level centre i sits at x = i).
        const double x = (p + 0.5) * double(w) / double(out_w_) - 0.5;
        const double b = std::floor(x);
        g.base[std::size_t(p)] = int(b);
        g.frac[std::size_t(p)] = x - b;
    }
    g.cos_offset = w / 2 + 2;
    g.cos_stride = std::size_t(w) + 2 * std::size_t(g.cos_offset);
    g.cos_dphi.resize(std::size_t(classes_) * g.cos_stride);
    for (int p = 0; p < classes_; ++p)
        for (std::size_t k = 0; k < g.cos_stride; ++k) {
            const double d = double(k) - g.cos_offset;
            g.cos_dphi[std::size_t(p) * g.cos_stride + k] = std::cos((d - g.frac[std::size_t(p)]) * kTwoPi / w);
        }
    g.rows = rows;
    g.laid_out = std::make_shared<std::once_flag>();
    return g;
}

const UninitVector<float>& LobeSummer::phases_of(const Geometry& g) const {
    std::call_once(*g.laid_out, [&] { g.phases = &g.level->phases(g.step, per_class_, g.rows); });
    return *g.phases;
}

void LobeSummer::lay_out() const {
    for (const Geometry& g : geometries_) phases_of(g);
}

namespace {

// Arc (radians) of one column of level row `row` at its edge nearer the equator.
double column_arc(int row, int level_width, int level_height) {
    const double edge = std::clamp(kPi / 2, row * kPi / level_height, (row + 1) * kPi / level_height);
    return std::sin(edge) * kTwoPi / level_width;
}

}  // namespace

int polar_merge_factor(int row, int level_width, int level_height, int out_width, double max_arc) {
    if (!(max_arc > 0)) return 1;
    const double arc = column_arc(row, level_width, level_height);
    const int g = std::gcd(level_width, out_width);
    int best = 1;
    for (int m = 2; m <= 64; m *= 2) {
        if (level_width % m != 0 || level_width / m < 8 || std::gcd(level_width / m, out_width) != g) break;
        if (m * arc <= max_arc) best = m;
    }
    return best;
}

double widest_merged_arc(int level_width, int level_height, int out_width, double max_arc) {
    double widest = 0;
    for (int j = 0; j < level_height; ++j) {
        const int m = polar_merge_factor(j, level_width, level_height, out_width, max_arc);
        if (m > 1) widest = std::max(widest, m * column_arc(j, level_width, level_height));
    }
    return widest;
}

namespace {

// Whether one channel's row of `width` values has no group of M columns rougher than allowed
// (row_smooth_enough). Eight groups are tested at once without an exit inside; each group's
// figures are those of a loop over it alone (the same sums in the same order).
template <int M>
bool channel_groups_smooth(const float* row, int width, double mean, double arc_scale, double max_arc_roughness) {
    // Eight groups side by side, group j's column k at row[g + j M + k]: each lane sums its own
    // group in the rule's order, and the lanes fill one vector register.
    constexpr int kGroups = 8;
    constexpr int kBlock = kGroups * M;
    using Doubles = double __attribute__((vector_size(kGroups * sizeof(double))));
    const auto column = [row](int g, int k) {  // column k of the eight groups from column g
        return Doubles{row[g + k],         row[g + M + k],     row[g + 2 * M + k], row[g + 3 * M + k],
                       row[g + 4 * M + k], row[g + 5 * M + k], row[g + 6 * M + k], row[g + 7 * M + k]};
    };
    int g = 0;
    for (; g + kBlock <= width; g += kBlock) {
        Doubles sum = {}, spread = {};
        for (int k = 0; k < M; ++k) sum += column(g, k);
        const Doubles group_mean = sum / double(M);
        for (int k = 0; k < M; ++k) {
            const Doubles d = column(g, k) - group_mean;
            spread += d < 0 ? -d : d;  // std::abs, NaN kept
        }
        const Doubles base = sum + double(M) * mean;
        // Both tests in every lane: NaN fails either, skipped as max() did.
        const auto rough = (base > 0) & (arc_scale * (spread / base) > max_arc_roughness);
        for (int j = 0; j < kGroups; ++j)
            if (rough[j]) return false;
    }
    for (; g < width; g += M) {  // rows narrower than eight groups, or their last groups
        double sum = 0, spread = 0;
        for (int k = 0; k < M; ++k) sum += row[g + k];
        for (int k = 0; k < M; ++k) spread += std::abs(row[g + k] - sum / M);
        const double base = sum + M * mean;
        if (base > 0 && arc_scale * (spread / base) > max_arc_roughness) return false;
    }
    return true;
}

// Whether row j's groups of m columns are smooth enough to merge: over the groups and
// channels, the largest roughness sum |L - group mean| / (sum L + m mean), times `arc_scale`,
// at most max_arc_roughness. Stops at the first block of groups with one over it: the search
// for a row's factor ends with a failing test, which used to read the whole row.
bool row_smooth_enough(const PreparedLevel& level, int j, int m, double mean, double arc_scale,
                       double max_arc_roughness) {
    // A row of no group with a base reads as roughness 0 (the old max() from 0): a limit below
    // that (negative, NaN) merges nothing.
    if (!(arc_scale * 0.0 <= max_arc_roughness)) return false;
    const int w = level.width();  // a multiple of m (polar_merge_factor)
    for (int c = 0; c < 3; ++c) {
        const float* row = level.plane(j, c);
        bool smooth = false;
        switch (m) {
            case 2: smooth = channel_groups_smooth<2>(row, w, mean, arc_scale, max_arc_roughness); break;
            case 4: smooth = channel_groups_smooth<4>(row, w, mean, arc_scale, max_arc_roughness); break;
            case 8: smooth = channel_groups_smooth<8>(row, w, mean, arc_scale, max_arc_roughness); break;
            case 16: smooth = channel_groups_smooth<16>(row, w, mean, arc_scale, max_arc_roughness); break;
            case 32: smooth = channel_groups_smooth<32>(row, w, mean, arc_scale, max_arc_roughness); break;
            case 64: smooth = channel_groups_smooth<64>(row, w, mean, arc_scale, max_arc_roughness); break;
            default: throw RuntimeError("internal: columns merged in groups of " + std::to_string(m));
        }
        if (!smooth) return false;
    }
    return true;
}

}  // namespace

std::vector<int> polar_merge_factors(const PreparedLevel& level, int out_width, double max_arc,
                                     double max_arc_roughness) {
    const int w = level.width(), h = level.height();
    std::vector<int> factor(static_cast<std::size_t>(h), 1);
    const double mean = level.power() / (4.0 * kPi);  // of max(R, G, B): at least each channel's
    for (int j = 0; j < h; ++j) {
        const double arc = column_arc(j, w, h);
        const int most = polar_merge_factor(j, w, h, out_width, max_arc);
        int& m = factor[std::size_t(j)];
        while (2 * m <= most && row_smooth_enough(level, j, 2 * m, mean, 2 * m * arc, max_arc_roughness)) m *= 2;
    }
    return factor;
}

LobeSummer::LobeSummer(const PreparedLevel& level, int out_w, int out_h, double shininess,
                       Accumulation accumulation, double max_merged_arc, double max_arc_roughness)
    : level_(level), out_w_(out_w), out_h_(out_h), n_(shininess), accumulation_(accumulation),
      classes_(out_w / std::gcd(level.width(), out_w)),
      per_class_(std::gcd(level.width(), out_w)) {
    const int h = level.height();
    // Each level row is read with one geometry, the level or a version of it with merged columns:
    // each version is laid out (and made) for its own rows only.
    std::map<int, std::vector<char>> rows_of;  // merge factor -> the level rows it is read for
    rows_of[1].assign(std::size_t(h), 0);
    merge_factors_ = polar_merge_factors(level, out_w, max_merged_arc, max_arc_roughness);
    const std::vector<int>& factor = merge_factors_;
    for (int j = 0; j < h; ++j) {
        std::vector<char>& rows = rows_of[factor[std::size_t(j)]];
        if (rows.empty()) rows.assign(std::size_t(h), 0);
        rows[std::size_t(j)] = 1;
    }
    geometries_.push_back(make_geometry(level, rows_of[1]));
    std::map<int, int> geometry_of;  // merge factor -> index in geometries_
    geometry_of[1] = 0;
    row_geometry_.assign(std::size_t(h), 0);
    for (int j = 0; j < h; ++j) {
        const int m = factor[std::size_t(j)];
        auto [it, inserted] = geometry_of.try_emplace(m, int(geometries_.size()));
        if (inserted) geometries_.push_back(make_geometry(level.merged_columns(m, rows_of[m]), rows_of[m]));
        row_geometry_[std::size_t(j)] = it->second;
    }
    out_cos_t_.resize(std::size_t(out_h));
    out_sin_t_.resize(std::size_t(out_h));
    for (int j = 0; j < out_h; ++j) {
        out_cos_t_[std::size_t(j)] = std::cos(row_theta(j, out_h));
        out_sin_t_[std::size_t(j)] = std::sin(row_theta(j, out_h));
    }
}

PreparedLevel::PreparedLevel(const PreparedLevel& parent, int m)
    : width_(parent.width_ / m), height_(parent.height_), threads_(parent.threads_),
      cos_t_(parent.cos_t_), sin_t_(parent.sin_t_), omega_(row_solid_angles(width_, height_)),
      // Upper bounds: averaging raises neither the largest value nor the max(R, G, B) power.
      max_value_(parent.max_value_), power_(parent.power_), parent_(&parent), merge_(m),
      built_(std::size_t(height_), 0) {
    planes_.resize(std::size_t(height_) * 3 * std::size_t(width_));  // rows written by ensure_rows
}

void PreparedLevel::make_rows(int first, int count) const {
    if (!parent_) return;
    std::vector<char> rows(std::size_t(height_), 0);
    for (int j = std::max(0, first); j < std::min(height_, first + count); ++j) rows[std::size_t(j)] = 1;
    ensure_rows(rows);
}

void PreparedLevel::ensure_rows(const std::vector<char>& rows) const {
    if (!parent_) return;  // a level made from an image has every row
    parent_->ensure_rows(rows);
    std::lock_guard lock(rows_mutex_);
    std::vector<int> missing;
    for (int j = 0; j < height_; ++j)
        if (rows[std::size_t(j)] && !built_[std::size_t(j)]) missing.push_back(j);
    parallel_for(int(missing.size()), threads_, [&](int k) {
        const int j = missing[std::size_t(k)];
        for (int c = 0; c < 3; ++c) {
            const float* src = parent_->plane(j, c);
            float* dst = planes_.data() + (std::size_t(j) * 3 + std::size_t(c)) * std::size_t(width_);
            for (int i = 0; i < width_; ++i) {
                double sum = 0;
                for (int k2 = 0; k2 < merge_; ++k2) sum += double(src[i * merge_ + k2]);
                dst[i] = float(sum / merge_);
            }
        }
    });
    for (int j : missing) built_[std::size_t(j)] = 1;
}

void PreparedLevel::release_layouts() const {
    {
        const std::lock_guard lock(phases_mutex_);
        phases_.clear();
    }
    {
        const std::lock_guard lock(merged_mutex_);
        merged_.clear();
    }
    const std::lock_guard lock(spectra_mutex_);
    spectra_.reset();
}

std::size_t PreparedLevel::layouts_held() const {
    std::size_t held = 0;
    {
        const std::lock_guard lock(phases_mutex_);
        held += phases_.size();
    }
    {
        const std::lock_guard lock(merged_mutex_);
        held += merged_.size();
    }
    const std::lock_guard lock(spectra_mutex_);
    return held + (spectra_ ? 1 : 0);
}

const PreparedLevel& PreparedLevel::merged_columns(int m) const {
    return merged_columns(m, std::vector<char>(std::size_t(height_), 1));
}

const PreparedLevel& PreparedLevel::merged_columns(int m, const std::vector<char>& rows) const {
    const PreparedLevel* version = nullptr;
    {
        std::lock_guard lock(merged_mutex_);
        const auto it = merged_.find(m);
        if (it != merged_.end()) version = it->second.get();
    }
    if (!version) {
        // An even m from the level with m/2 merged, two columns at a time: the powers of two the
        // summer asks for then take half-size passes instead of full ones each. Made without
        // rows (cheap); its rows are built below, as they are asked for.
        const bool halves = m > 2 && m % 2 == 0;
        const PreparedLevel& parent = halves ? merged_columns(m / 2, std::vector<char>(std::size_t(height_), 0)) : *this;
        auto made = std::make_unique<PreparedLevel>(parent, halves ? 2 : m);
        std::lock_guard lock(merged_mutex_);
        version = merged_.try_emplace(m, std::move(made)).first->second.get();
    }
    version->ensure_rows(rows);
    return *version;
}

const UninitVector<float>& PreparedLevel::phases(int step, int per_class) const {
    return phases(step, per_class, std::vector<char>(std::size_t(height_), 1));
}

const UninitVector<float>& PreparedLevel::phases(int step, int per_class, const std::vector<char>& rows) const {
    ensure_rows(rows);  // before phases_mutex_: a merged level's rows come from its parent's
    std::lock_guard lock(phases_mutex_);
    PhaseLayout& layout = phases_[{step, per_class}];
    UninitVector<float>& p = layout.values;
    // step * per_class = width, so the first per_class values of a phase row
    // never wrap and the second per_class values repeat them.
    const std::size_t half = std::size_t(per_class);
    const std::size_t stride = phase_stride(per_class);
    const std::size_t st = std::size_t(step);
    // Allocated once (not touched: every value read is written below first); rows laid out as
    // they are asked for, since a row is read with one geometry only (LobeSummer).
    if (p.empty()) {
        p.resize(std::size_t(height_) * 3 * st * stride);
        layout.built.assign(std::size_t(height_), 0);
    }
    std::vector<int> missing;
    for (int j = 0; j < height_; ++j)
        if (rows[std::size_t(j)] && !layout.built[std::size_t(j)]) missing.push_back(j);
    parallel_for(int(missing.size()), threads_, [&](int k) {
        const int j = missing[std::size_t(k)];
        for (std::size_t c = 0; c < 3; ++c) {
            const float* src = plane(j, int(c));
            float* row = p.data() + (std::size_t(j) * 3 + c) * st * stride;  // phase 0 of this channel
            if (st == 1) {
                std::copy_n(src, half, row);
            } else if (st == 2) {  // one pass for both phases (a deinterleave)
                float* even = row;
                float* odd = row + stride;
                for (std::size_t t = 0; t < half; ++t) {
                    even[t] = src[2 * t];
                    odd[t] = src[2 * t + 1];
                }
            } else {
                for (std::size_t ph = 0; ph < st; ++ph)
                    for (std::size_t t = 0; t < half; ++t) row[ph * stride + t] = src[t * st + ph];
            }
            for (std::size_t ph = 0; ph < st; ++ph) std::copy_n(row + ph * stride, half, row + ph * stride + half);
        }
    });
    for (int j : missing) layout.built[std::size_t(j)] = 1;
    return p;
}

CapMax::CapMax(const PreparedLevel& level, double radius, int threads)
    : width_(level.width()), height_(level.height()), radius_(radius) {
    const double row_height = kPi / height_;
    block_rows_ = std::clamp(int(radius / row_height), 1, height_);
    blocks_ = (height_ + block_rows_ - 1) / block_rows_;
    levels_ = 1;
    while ((1 << levels_) <= width_) ++levels_;
    table_.resize(std::size_t(levels_) * std::size_t(blocks_) * std::size_t(width_));  // all written below
    parallel_for(blocks_, threads, [&](int b) {
        float* block = table_.data() + std::size_t(b) * std::size_t(width_);
        std::fill(block, block + width_, 0.0f);
        for (int j = b * block_rows_; j < std::min(height_, (b + 1) * block_rows_); ++j)
            for (int i = 0; i < width_; ++i)
                block[i] = std::max({block[i], level.plane(j, 0)[i], level.plane(j, 1)[i], level.plane(j, 2)[i]});
        for (int k = 1; k < levels_; ++k) {
            const float* prev =
                table_.data() + (std::size_t(k - 1) * std::size_t(blocks_) + std::size_t(b)) * std::size_t(width_);
            float* cur = table_.data() + (std::size_t(k) * std::size_t(blocks_) + std::size_t(b)) * std::size_t(width_);
            // Two loops, not one with the cyclic index's test in it: each runs in vector lanes
            // (one loop ran texel by texel, 60 % of this constructor in `perf`).
            const int half = std::min(1 << (k - 1), width_);
            for (int i = 0; i < width_ - half; ++i) cur[i] = std::max(prev[i], prev[i + half]);
            for (int i = width_ - half; i < width_; ++i) cur[i] = std::max(prev[i], prev[i + half - width_]);
        }
    });
    block_max_.resize(std::size_t(blocks_));
    for (int b = 0; b < blocks_; ++b) {
        const float* row = table_.data() + std::size_t(b) * std::size_t(width_);
        block_max_[std::size_t(b)] = largest_or_zero(row, std::size_t(width_));  // every entry is >= 0
    }
}

double CapMax::band_max(const Band& band) const {
    float best = 0;
    for (int b = band.first_block; b <= band.last_block; ++b) best = std::max(best, block_max_[std::size_t(b)]);
    return best;
}

float CapMax::range_max(int block, int first, int count) const {
    const int k = std::bit_width(unsigned(count)) - 1;  // largest 2^k <= count: two windows cover the range
    const float* t =
        table_.data() + (std::size_t(k) * std::size_t(blocks_) + std::size_t(block)) * std::size_t(width_);
    // first is in [-width, width) and count <= width (see query): wrap without a division.
    int start = first < 0 ? first + width_ : first;
    int last_start = start + count - (1 << k);
    if (last_start >= width_) last_start -= width_;
    return std::max(t[start], t[last_start]);
}

CapMax::Band CapMax::band(double theta) const {
    Band b;
    const int j0 = std::clamp(int(std::floor((theta - radius_) / kPi * height_)), 0, height_ - 1);
    const int j1 = std::clamp(int(std::floor((theta + radius_) / kPi * height_)), 0, height_ - 1);
    b.first_block = j0 / block_rows_;
    b.last_block = j1 / block_rows_;
    if (theta - radius_ > 0 && theta + radius_ < kPi) {
        // Widest azimuth of a cap that holds no pole.
        b.whole_rows = false;
        b.half_width = std::asin(std::min(1.0, std::sin(radius_) / std::sin(theta)));
    }
    return b;
}

double CapMax::query(const Band& band, double phi) const {
    int first = 0, count = width_;
    if (!band.whole_rows) {
        first = int(std::floor((phi - band.half_width + kPi) / kTwoPi * width_));
        count = std::min(width_, int(std::floor((phi + band.half_width + kPi) / kTwoPi * width_)) - first + 1);
    }
    // phi in [-pi, pi) and half_width <= pi/2 keep first in [-width, width).
    first = std::clamp(first, -width_, width_ - 1);
    float best = 0;
    for (int b = band.first_block; b <= band.last_block; ++b) best = std::max(best, range_max(b, first, count));
    return best;
}

LobeSums LobeSummer::make_sums(const std::vector<int>* rows, const std::vector<ColumnRuns>* columns) const {
    LobeSums s;
    s.out_w = out_w_;
    s.out_h = out_h_;
    s.classes = classes_;
    if (columns && rows && columns->size() == rows->size()) {
        // Per row, the window from the first to the last column that the runs or sum_row's
        // widened class runs reach.
        s.slot.assign(std::size_t(out_h_), -1);
        std::size_t total = 0;
        for (std::size_t k = 0; k < rows->size(); ++k) {
            const int row = (*rows)[k];
            if (s.slot[std::size_t(row)] >= 0)
                throw RuntimeError("internal: make_sums with column runs needs distinct rows");
            int lo = out_w_, hi = 0;
            for (const auto& [first, last] : (*columns)[k])
                if (first < last) {
                    lo = std::min(lo, first);
                    hi = std::max(hi, last);
                }
            for (int cls = 0; cls < classes_; ++cls)
                for (const auto& [q0, q1] : class_runs(cls, (*columns)[k])) {
                    lo = std::min(lo, q0 * classes_ + cls);
                    hi = std::max(hi, (q1 - 1) * classes_ + cls + 1);
                }
            if (hi < lo) hi = lo = 0;
            s.slot[std::size_t(row)] = int(k);
            s.row_start.push_back(total);
            s.col_lo.push_back(lo);
            s.col_hi.push_back(hi);
            total += std::size_t(hi - lo);
        }
        s.num.resize(total * 3);
        s.den.assign(std::size_t(classes_) * std::size_t(out_h_), 0.0);
        s.cmax.assign(std::size_t(classes_) * std::size_t(out_h_), 0.0);
        return s;
    }
    std::size_t stored = std::size_t(out_h_);
    if (rows && int(rows->size()) < out_h_) {
        s.slot.assign(std::size_t(out_h_), -1);
        int next = 0;
        for (int row : *rows)
            if (s.slot[std::size_t(row)] < 0) s.slot[std::size_t(row)] = next++;
        stored = std::size_t(next);
    }
    s.num.resize(std::size_t(out_w_) * stored * 3);
    s.den.assign(std::size_t(classes_) * std::size_t(out_h_), 0.0);
    s.cmax.assign(std::size_t(classes_) * std::size_t(out_h_), 0.0);
    return s;
}

double LobeSummer::cmax(int out_row, int cls) const {
    // Per geometry, the azimuth to the nearest texel centre of this class.
    double cn[8];
    const std::size_t count = std::min<std::size_t>(geometries_.size(), 8);
    for (std::size_t k = 0; k < count; ++k) {
        const double f = geometries_[k].frac[std::size_t(cls)];
        cn[k] = std::cos(kTwoPi / geometries_[k].width * std::min(f, 1.0 - f));
    }
    const double ctr = out_cos_t_[std::size_t(out_row)];
    const double str = out_sin_t_[std::size_t(out_row)];
    double best = -1.0;
    for (int j = 0; j < level_.height(); ++j)
        best = std::max(best, str * level_.sin_theta(j) * cn[row_geometry_[std::size_t(j)]] + ctr * level_.cos_theta(j));
    return best;
}

double LobeSummer::underflow_cos(double cmax_value) const {
    if (n_ <= 0) return 0.0;
    return cmax_value * std::exp(kLogSmallestNormal / n_);
}

void LobeSummer::weights(const Geometry& g, int cls, int d_lo, int count, double a, double b, double inv_cmax,
                         double* w) const {
    const double* cs = g.cos_dphi.data() + std::size_t(cls) * g.cos_stride + std::size_t(d_lo + g.cos_offset);
    // Ratio to the largest cosine; conventions: only r.w > 0 counts, also for n = 0.
    for (int d = 0; d < count; ++d) {
        const double c = a * cs[d] + b;
        w[d] = c > 0 ? c * inv_cmax : 0.0;
    }
    raise_to_power(w, count, n_);
}

namespace {

// Register blocking: kBlock output columns of all three channels stay in
// registers while every term of a chunk is applied; each term costs three
// unit-stride loads of kBlock texels. Without it, every term would load and
// store the whole accumulator row (measured ~1.2 multiply-adds per cycle).
constexpr int kBlock = 16;

// Columns [q, q1) one at a time in double: what is left past the last whole
// block (a class narrower than kBlock), for both accumulations.
template <typename Term>
void apply_terms_scalar(const std::vector<Term>& terms, int q, int q1, std::size_t channel_stride,
                        double* acc_r, double* acc_g, double* acc_b) {
    for (; q < q1; ++q)
        for (const Term& term : terms) {
            acc_r[q] += term.weight * double(term.texels[q]);
            acc_g[q] += term.weight * double(term.texels[q + channel_stride]);
            acc_b[q] += term.weight * double(term.texels[q + 2 * channel_stride]);
        }
}

// Double accumulation (exact): every multiply-add in double.
template <typename Term>
void apply_terms_double(const std::vector<Term>& terms, int q0, int q1, std::size_t channel_stride,
                        double* acc_r, double* acc_g, double* acc_b) {
    int q = q0;
    for (; q + kBlock <= q1; q += kBlock) {
        double ar[kBlock], ag[kBlock], ab[kBlock];
        for (int t = 0; t < kBlock; ++t) {
            ar[t] = acc_r[q + t];
            ag[t] = acc_g[q + t];
            ab[t] = acc_b[q + t];
        }
        for (const Term& term : terms) {
            const float* pr = term.texels + q;
            const float* pg = pr + channel_stride;
            const float* pb = pg + channel_stride;
            const double wt = term.weight;
#pragma omp simd
            for (int t = 0; t < kBlock; ++t) {
                ar[t] += wt * double(pr[t]);
                ag[t] += wt * double(pg[t]);
                ab[t] += wt * double(pb[t]);
            }
        }
        for (int t = 0; t < kBlock; ++t) {
            acc_r[q + t] = ar[t];
            acc_g[q + t] = ag[t];
            acc_b[q + t] = ab[t];
        }
    }
    apply_terms_scalar(terms, q, q1, channel_stride, acc_r, acc_g, acc_b);
}

// Float runs (cone): runs of kFloatRun terms are summed in float, which needs
// no float->double conversions (1.9x faster on AVX-512), and each run's sum is
// added to double accumulators. A run of k non-negative terms in float is
// within k * 2^-24 of its sum (1.9e-6 for 32, ~3e-7 in practice), so a
// constant map still comes back to ~1e-6.
constexpr std::size_t kFloatRun = 32;

// kBlock floats as one value the compiler keeps in registers (GCC/Clang
// vector extension: AVX-512 on the build machine, 4 NEON registers on ARM).
using FloatBlock = float __attribute__((vector_size(kBlock * sizeof(float))));

inline FloatBlock load_block(const float* p) {
    FloatBlock v;
    std::memcpy(&v, p, sizeof v);
    return v;
}

template <typename Term>
void apply_terms_float(const std::vector<Term>& terms, int q0, int q1, std::size_t channel_stride,
                       double* acc_r, double* acc_g, double* acc_b) {
    // The weights as float once per chunk, not once per block.
    thread_local std::vector<float> weights;
    weights.resize(terms.size());
    for (std::size_t k = 0; k < terms.size(); ++k) weights[k] = float(terms[k].weight);
    int q = q0;
    for (; q + kBlock <= q1; q += kBlock) {
        for (std::size_t first = 0; first < terms.size(); first += kFloatRun) {
            const std::size_t end = std::min(terms.size(), first + kFloatRun);
            // Two sets of accumulators (even and odd terms): a multiply-add waits
            // ~4 cycles for the previous one into the same register, so one set
            // would leave the FMA units idle half of the time.
            FloatBlock fr = {}, fg = {}, fb = {}, fr2 = {}, fg2 = {}, fb2 = {};
            std::size_t k = first;
            for (; k + 1 < end; k += 2) {
                const float* pr = terms[k].texels + q;
                const float* pr2 = terms[k + 1].texels + q;
                const float wt = weights[k];
                const float wt2 = weights[k + 1];
                fr += wt * load_block(pr);
                fr2 += wt2 * load_block(pr2);
                fg += wt * load_block(pr + channel_stride);
                fg2 += wt2 * load_block(pr2 + channel_stride);
                fb += wt * load_block(pr + 2 * channel_stride);
                fb2 += wt2 * load_block(pr2 + 2 * channel_stride);
            }
            if (k < end) {
                const float* pr = terms[k].texels + q;
                const float wt = weights[k];
                fr += wt * load_block(pr);
                fg += wt * load_block(pr + channel_stride);
                fb += wt * load_block(pr + 2 * channel_stride);
            }
            fr += fr2;
            fg += fg2;
            fb += fb2;
            for (int t = 0; t < kBlock; ++t) {
                acc_r[q + t] += double(fr[t]);
                acc_g[q + t] += double(fg[t]);
                acc_b[q + t] += double(fb[t]);
            }
        }
    }
    apply_terms_scalar(terms, q, q1, channel_stride, acc_r, acc_g, acc_b);
}

}  // namespace

void LobeSummer::flush_terms(const std::vector<Term>& terms, const ColumnRuns& q_runs, std::size_t channel_stride,
                             double* acc_r, double* acc_g, double* acc_b) const {
    for (const auto& [q0, q1] : q_runs) {
        if (accumulation_ == Accumulation::Double)
            apply_terms_double(terms, q0, q1, channel_stride, acc_r, acc_g, acc_b);
        else
            apply_terms_float(terms, q0, q1, channel_stride, acc_r, acc_g, acc_b);
    }
}

LobeSummer::RowWindow LobeSummer::window(int out_row, int cls, double c_min) const {
    RowWindow win;
    win.cmax = cmax(out_row, cls);
    win.lowest_cos = std::max(c_min, underflow_cos(win.cmax));
    // Rows whose best cosine cos(theta_r - theta_k) can reach lowest_cos.
    const int h = level_.height();
    const double theta_r = row_theta(out_row, out_h_);
    const double reach = std::acos(std::clamp(win.lowest_cos, -1.0, 1.0));
    win.first = std::max(0, int(std::floor((theta_r - reach) / kPi * h - 0.5)) - 1);
    win.last = std::min(h - 1, int(std::ceil((theta_r + reach) / kPi * h - 0.5)) + 1);
    return win;
}

void LobeSummer::columns_above(const Geometry& g, int cls, double bound, double a, double b, int& d_lo,
                               int& count) const {
    const int w = g.width;
    const double f = g.frac[std::size_t(cls)];
    const double q = a > 1e-300 ? (bound - b) / a : (b >= bound ? -2.0 : 2.0);
    count = 0;
    if (q > 1.0) return;
    if (q <= -1.0) {
        d_lo = int(std::ceil(f - 0.5 * w));
        count = w;
    } else {
        const double half = std::acos(q) * (w / kTwoPi);
        d_lo = int(std::ceil(f - half));
        count = std::max(0, std::min(w, int(std::floor(f + half)) - d_lo + 1));
    }
}

LobeSummer::RowTerms LobeSummer::row_terms(int out_row, int cls, const RowWindow& win, int jk, double* w) const {
    const Geometry& g = geometries_[std::size_t(row_geometry_[std::size_t(jk)])];
    RowTerms t;
    t.level = g.level;
    t.base = g.base[std::size_t(cls)];
    t.frac = g.frac[std::size_t(cls)];
    t.step = g.step;
    t.omega = g.level->solid_angle(jk);
    const double a = out_sin_t_[std::size_t(out_row)] * level_.sin_theta(jk);
    const double b = out_cos_t_[std::size_t(out_row)] * level_.cos_theta(jk);
    columns_above(g, cls, win.lowest_cos, a, b, t.first, t.count);
    if (t.count > 0) weights(g, cls, t.first, t.count, a, b, 1.0 / win.cmax, w);
    return t;
}

void LobeSummer::sum_row(int out_row, double c_min, LobeSums& sums, const ColumnRuns* columns,
                         double c_inner) const {
    const double ctr = out_cos_t_[std::size_t(out_row)];
    const double str = out_sin_t_[std::size_t(out_row)];
    std::vector<double> wbuf(std::size_t(level_.width()) + 2);
    // One list of terms per geometry: their texel runs have different strides.
    std::vector<std::vector<Term>> terms(geometries_.size());
    for (auto& t : terms) t.reserve(kTermChunk);
    const auto channel_stride = [&](std::size_t k) {
        return std::size_t(geometries_[k].step) * PreparedLevel::phase_stride(per_class_);
    };
    std::vector<double> acc(std::size_t(per_class_) * 3);
    double* acc_r = acc.data();
    double* acc_g = acc_r + per_class_;
    double* acc_b = acc_g + per_class_;

    for (const Geometry& g : geometries_) phases_of(g);
    for (int cls = 0; cls < classes_; ++cls) {
        const RowWindow win = window(out_row, cls, c_min);
        const double cm = win.cmax;
        const double inv_cm = 1.0 / cm;
        const double lo = win.lowest_cos;
        std::fill(acc.begin(), acc.end(), 0.0);
        double den = 0;
        // Runs of this class's column indices q (column = q * classes + cls).
        const ColumnRuns q_runs = columns ? class_runs(cls, *columns) : ColumnRuns{{0, per_class_}};

        const auto add_columns = [&](std::size_t gi, int jk, double a, double b, int d_lo, int count) {
            if (count <= 0) return;
            const Geometry& g = geometries_[gi];
            const int w = g.width;
            std::vector<Term>& list = terms[gi];
            // Weights depend on the column offset only (shared by the class).
            weights(g, cls, d_lo, count, a, b, inv_cm, wbuf.data());
            double wsum = 0;
            for (int d = 0; d < count; ++d) wsum += wbuf[std::size_t(d)];
            if (wsum == 0) return;
            const double omega = g.level->solid_angle(jk);  // of this geometry's texels
            den += omega * wsum;
            // One weight times a whole class of output columns: the (weight, texel
            // run) pairs are collected and applied in blocks (flush_terms).
            for (int d = 0; d < count; ++d) {
                const double wd = wbuf[std::size_t(d)] * omega;
                if (wd == 0) continue;
                int x = (g.base[std::size_t(cls)] + d_lo + d) % w;
                if (x < 0) x += w;
                list.push_back({wd, phase(g, jk, x % g.step) + x / g.step});
                if (list.size() == kTermChunk) {
                    flush_terms(list, q_runs, channel_stride(gi), acc_r, acc_g, acc_b);
                    list.clear();
                }
            }
        };
        const double lo_inner = c_inner <= 1.0 ? std::max(c_inner, underflow_cos(cm)) : 2.0;

        for (int jk = win.first; jk <= win.last; ++jk) {
            const double a = str * level_.sin_theta(jk);
            const double b = ctr * level_.cos_theta(jk);
            const std::size_t gi = std::size_t(row_geometry_[std::size_t(jk)]);
            const Geometry& g = geometries_[gi];
            int d_lo = 0, count = 0;
            columns_above(g, cls, lo, a, b, d_lo, count);
            if (count == 0) continue;
            int in_lo = 0, in_count = 0;
            if (lo_inner <= 1.0) columns_above(g, cls, lo_inner, a, b, in_lo, in_count);
            if (in_count == 0) {
                add_columns(gi, jk, a, b, d_lo, count);
            } else {  // the annulus: the columns left and right of the inner cone
                add_columns(gi, jk, a, b, d_lo, in_lo - d_lo);
                add_columns(gi, jk, a, b, in_lo + in_count, d_lo + count - (in_lo + in_count));
            }
        }
        for (std::size_t gi = 0; gi < terms.size(); ++gi) {
            flush_terms(terms[gi], q_runs, channel_stride(gi), acc_r, acc_g, acc_b);
            terms[gi].clear();
        }
        const std::size_t rc = std::size_t(out_row) * std::size_t(classes_) + std::size_t(cls);
        sums.den[rc] = den;
        sums.cmax[rc] = cm;
        for (const auto& [q0, q1] : q_runs)
        for (int q_idx = q0; q_idx < q1; ++q_idx) {
            const int col = q_idx * classes_ + cls;
            double* o = sums.num.data() + sums.texel(out_row, col) * 3;
            o[0] = acc_r[q_idx];
            o[1] = acc_g[q_idx];
            o[2] = acc_b[q_idx];
        }
    }
}

LobeSummer::ColumnRuns LobeSummer::class_runs(int cls, const ColumnRuns& columns) const {
    // Runs widened to whole blocks of kBlock (the vector path); the extra columns' sums are
    // written too and left unread by the caller.
    ColumnRuns q_runs;
    for (const auto& [first, last] : columns) {
        int q0 = std::max(0, (first - cls + classes_ - 1) / classes_);
        int q1 = std::min(per_class_, (last - cls + classes_ - 1) / classes_);
        if (q1 <= q0) continue;
        q0 = q0 / kBlock * kBlock;
        q1 = std::min(per_class_, (q1 + kBlock - 1) / kBlock * kBlock);
        if (!q_runs.empty() && q0 <= q_runs.back().second)
            q_runs.back().second = std::max(q_runs.back().second, q1);
        else
            q_runs.emplace_back(q0, q1);
    }
    return q_runs;
}

void raise_to_power(double* x, int count, double n) {
    if (n != std::floor(n) || n > double(1LL << 40)) {
        for (int d = 0; d < count; ++d) x[d] = x[d] > 0 ? std::pow(x[d], n) : 0.0;
        return;
    }
    if (n == 0) {
        for (int d = 0; d < count; ++d) x[d] = x[d] > 0 ? 1.0 : 0.0;
        return;
    }
    // x^n by binary exponentiation, one pass per bit so that each pass
    // vectorises; relative error ~ 2 log2(n) ulp.
    thread_local std::vector<double> base;
    base.assign(x, x + count);
    bool first = true;
    for (long long e = (long long)n; e > 0; e >>= 1) {
        if (e & 1) {
            if (first) {
                std::copy(base.begin(), base.end(), x);
                first = false;
            } else {
                const double* bp = base.data();
#pragma omp simd
                for (int d = 0; d < count; ++d) x[d] *= bp[d];
            }
        }
        if (e > 1) {
            double* bp = base.data();
#pragma omp simd
            for (int d = 0; d < count; ++d) bp[d] *= bp[d];
        }
    }
}

HdrImage finish_sums(const LobeSums& sums) {
    HdrImage out(sums.out_w, sums.out_h);
    for (int j = 0; j < sums.out_h; ++j) {
        if (!sums.stored(j)) continue;
        float* row = out.row(j);
        for (int i = sums.first_column(j); i < sums.end_column(j); ++i) {
            const double den = sums.den[std::size_t(j) * std::size_t(sums.classes) +
                                        std::size_t(sums.class_of(i))];
            const double* num = sums.num.data() + sums.texel(j, i) * 3;
            for (int c = 0; c < 3; ++c)
                row[3 * i + c] = den > 0 ? float(std::max(0.0, num[c] / den)) : 0.0f;
        }
    }
    return out;
}

}  // namespace glint::convolution
