// The cone's first pass by Fourier transforms along the rows (fourier_pass.hpp).
//
// For output row r and level row k, the first pass adds, for every output column q,
//   sum_d w[d] omega_k L_k[base + q step + first + d]
// which is the level row correlated with the kernel w placed at offsets p = first + d - frac
// from the output column's centre c_q = base + frac + q step. With F_k the row's spectrum
// (length W) and H(m) = sum_d w[d] e^{+2 pi i m p_d / W},
//   out(q) = 1/W sum_m [sum_k omega_k H_k(m) F_k(m)] e^{2 pi i m c_q / W},
// and since c_q = c_0 + q W / out_w, the bins fold modulo out_w into one inverse transform
// of length out_w per channel. A kernel symmetric about the centre has a real H: a cosine
// sum over half its columns, read from a table.
#include "appliance/convolution/fourier_pass.hpp"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <complex>
#include <cstddef>
#include <cstdlib>
#include <cstring>
#include <limits>
#include <mutex>
#include <string>

#include "appliance/convolution/fft.hpp"
#include "appliance/core/equirect.hpp"
#include "appliance/core/errors.hpp"
#include "appliance/core/lane_extrema.hpp"
#include "appliance/core/parallel.hpp"

namespace glint::convolution {

namespace {

using Complex = std::complex<double>;

// Kernels of at most this many columns, symmetric about the output column's centre, have
// their spectrum as a cosine sum from a table (half their columns times W/2 multiply-adds);
// wider ones (rows near a pole, where the cone holds most of the row) from a transform of
// their own, which costs about as much as 256 columns would.
constexpr int kDirectMaxColumns = 256;

// Bins summed in registers at a time: kBlocks values of kLanes doubles (GCC/Clang vector
// extension; two AVX-512 registers per array on the build machine). Three channels' real and
// imaginary parts are 12 of them, the kernel's cosine sum 2 more.
constexpr std::size_t kLanes = 8;
constexpr std::size_t kBlocks = 2;
constexpr std::size_t kBins = kLanes * kBlocks;
using DoubleBlock = double __attribute__((vector_size(kLanes * sizeof(double))));

inline DoubleBlock load(const double* p) {
    DoubleBlock v;
    std::memcpy(&v, p, sizeof v);
    return v;
}
inline void store(double* p, DoubleBlock v) { std::memcpy(p, &v, sizeof v); }

bool power_of_two(int n) { return n > 0 && is_fft_length(std::size_t(n)); }

}  // namespace

// Per level (or merged version): the transform, tables, and each row's three spectra as
// planar real and imaginary parts (bins each), made when a row is first read.
struct PreparedLevel::RowSpectra {
    explicit RowSpectra(const PreparedLevel& level)
        : width(level.width()), bins(width / 2 + 1), plan(std::size_t(width)),
          groups((level.height() + int(kRowsPerGroup) - 1) / int(kRowsPerGroup)),
          group_lock(new std::mutex[std::size_t(groups)]), made(new std::atomic<bool>[std::size_t(groups)]) {
        for (int g = 0; g < groups; ++g) made[std::size_t(g)].store(false, std::memory_order_relaxed);
        turns.resize(2 * std::size_t(width));
        for (std::size_t k = 0; k < turns.size(); ++k) turns[k] = std::polar(1.0, kPi * double(k) / width);
        // cos(pi m j / W) = Re turns[m j mod 2W], the index stepped without a division.
        const int table_rows = std::min(kDirectMaxColumns, width) + 1;
        cos_table.resize(std::size_t(table_rows) * std::size_t(bins));
        for (int j = 0; j < table_rows; ++j) {
            std::size_t index = 0;
            double* row = cos_table.data() + std::size_t(j) * std::size_t(bins);
            for (int m = 0; m < bins; ++m) {
                row[m] = turns[index].real();
                index += std::size_t(j);
                if (index >= turns.size()) index -= turns.size();
            }
        }
        // Not zeroed: a row's spectra are written when it is first read (a fresh page costs
        // more than writing it; docs/convolution.md, "Huge pages").
        values.resize(std::size_t(level.height()) * 6 * std::size_t(bins));
    }

    // The row's spectra: channel c's real parts at [2 c bins, (2 c + 1) bins), then its
    // imaginary parts. Rows are transformed kRowsPerGroup at a time (RealFftPlan::forward_batch,
    // one row per vector lane), each group once, by the first thread that reads one of its rows.
    const double* row(const PreparedLevel& level, int j) {
        const std::size_t g = std::size_t(j) / kRowsPerGroup;
        if (!made[g].load(std::memory_order_acquire)) {
            const std::lock_guard lock(group_lock[g]);
            if (!made[g].load(std::memory_order_relaxed)) {
                const int first = int(g * kRowsPerGroup);
                const std::size_t count = std::min<std::size_t>(kRowsPerGroup, std::size_t(level.height() - first));
                // A version with merged columns makes only the rows its readers asked for: the
                // group's other rows are made here, so that no lane reads an unmade row (whose
                // spectrum would be kept as made when a later reader asks for that row).
                level.make_rows(first, int(count));
                for (int c = 0; c < 3; ++c) {
                    const float* x[kRowsPerGroup];
                    double* re[kRowsPerGroup];
                    double* im[kRowsPerGroup];
                    for (std::size_t b = 0; b < count; ++b) {
                        x[b] = level.plane(first + int(b), c);
                        re[b] = values.data() + ((std::size_t(first) + b) * 6 + 2 * std::size_t(c)) * std::size_t(bins);
                        im[b] = re[b] + bins;
                    }
                    plan.forward_batch(x, re, im, count);
                }
                made[g].store(true, std::memory_order_release);
            }
        }
        return values.data() + std::size_t(j) * 6 * std::size_t(bins);
    }

    static constexpr std::size_t kRowsPerGroup = FftPlan::kBatch;
    int width, bins;
    RealFftPlan plan;
    int groups;                                    // of kRowsPerGroup rows
    std::unique_ptr<std::mutex[]> group_lock;      // per group: held while it is transformed
    std::unique_ptr<std::atomic<bool>[]> made;     // per group: its spectra are written
    std::vector<Complex> turns;     // e^{i pi k / width}, k in [0, 2 width)
    std::vector<double> cos_table;  // [j * bins + m] = cos(pi m j / width)
    UninitVector<double> values;    // 6 bins per row
};

PreparedLevel::RowSpectra& PreparedLevel::row_spectra() const {
    const std::lock_guard lock(spectra_mutex_);
    if (!spectra_) spectra_ = std::make_shared<RowSpectra>(*this);
    return *spectra_;
}

const double* PreparedLevel::row_spectrum(int j) const { return row_spectra().row(*this, j); }

// What one output row reads: its level rows grouped by the version of the level they are read
// from (the level, or one with merged columns near a pole), each with its kernel's spectrum as
// cosine-table rows and weights (a symmetric kernel) or its own transform.
struct FourierRowPlan {
    struct Item {
        const double* spectra = nullptr;
        int jk = 0;                     // the level row
        int first_pair = 0, pairs = 0;  // symmetric: column pairs in pair_weight / pair_row
        // Else: where its H (planar, 2 bins of its group's version) starts in kernels. An
        // offset, not an index: the versions' bins differ, and an index times this group's
        // bins pointed a row next to a pole at another version's H (merged columns near a
        // pole read through their own transform before the level's rows: 20 % off).
        std::ptrdiff_t kernel = -1;
    };
    struct Group {
        const PreparedLevel* level = nullptr;
        PreparedLevel::RowSpectra* spectra = nullptr;
        long long two_centre = 0;  // 2 (base + frac): output column 0's centre, doubled
        std::vector<Item> items;   // ascending level rows
    };
    std::vector<Group> groups;
    std::vector<double> pair_weight;
    // The index of the group reading `level` (one per version), or groups.size().
    std::size_t group_index(const PreparedLevel* level) const {
        std::size_t k = 0;
        while (k < groups.size() && groups[k].level != level) ++k;
        return k;
    }
    std::vector<const double*> pair_row;
    std::vector<double> kernels;
    double den = 0, cmax = 1;
};

struct FourierFirstPass::Impl {
    Impl(const LobeSummer& s, int w, int t) : summer(s), out_w(w), threads(t), out_plan(std::size_t(w)) {}

    const LobeSummer& summer;
    int out_w, threads;
    RealFftPlan out_plan;

    void plan_row(int row, double c0, FourierRowPlan& plan) const;
    // Whether `mirror` (the output row mirrored about the equator) reads the level rows of
    // `plan` mirrored, each from the same version with the same kernel (to 1e-12 of its
    // largest weight), so that one kernel spectrum serves both rows.
    bool mirrored(const FourierRowPlan& plan, const FourierRowPlan& mirror) const;
    // Sums output row `row` (and `mirror_row` from `mirror`, when given: the kernels' spectra
    // from `plan`, computed once for both) into `sums`.
    void sum(int row, const FourierRowPlan& plan, int mirror_row, const FourierRowPlan* mirror, LobeSums& sums) const;
};

bool FourierFirstPass::applies(int level_width, int level_height, int out_width) {
    return power_of_two(level_width) && power_of_two(out_width) && out_width >= 2 && out_width <= level_width &&
           (long long)level_width * level_height <= kMaxLevelTexels;
}

bool FourierFirstPass::pays_off(int level_width, int level_height, int out_width) {
    return applies(level_width, level_height, out_width) && 2 * out_width >= level_width;
}

FourierFirstPass::FourierFirstPass(const LobeSummer& summer, int out_width, int threads) {
    const int level_width = summer.level().width();
    if (!power_of_two(level_width) || !power_of_two(out_width) || out_width < 2 || summer.classes() != 1)
        throw RuntimeError("internal: the Fourier first pass cannot sum " + std::to_string(out_width) +
                           " columns from " + std::to_string(level_width));
    impl_ = std::make_unique<Impl>(summer, out_width, threads);
}

FourierFirstPass::~FourierFirstPass() = default;

void FourierFirstPass::Impl::plan_row(int row, double c0, FourierRowPlan& plan) const {
    using Item = FourierRowPlan::Item;
    using Group = FourierRowPlan::Group;
    std::vector<double> w(std::size_t(summer.level().width()) + 2);  // up to a whole row of the level
    std::vector<double> kernel;
    std::vector<Complex> kernel_spectrum;
    const LobeSummer::RowWindow win = summer.window(row, 0, c0);
    plan.cmax = win.cmax;
    for (int jk = win.first; jk <= win.last; ++jk) {
        const LobeSummer::RowTerms t = summer.row_terms(row, 0, win, jk, w.data());
        if (t.count <= 0) continue;
        double wsum = 0;
        for (int d = 0; d < t.count; ++d) wsum += w[std::size_t(d)];
        if (wsum == 0) continue;
        plan.den += t.omega * wsum;

        // One column class: output centres sit on a column or halfway between two.
        const long long two_frac = std::llround(2.0 * t.frac);
        if ((two_frac != 0 && two_frac != 1) || 2.0 * t.frac != double(two_frac))
            throw RuntimeError("internal: the Fourier first pass needs output centres on or halfway between columns");
        const std::size_t g = plan.group_index(t.level);
        if (g == plan.groups.size()) plan.groups.push_back({t.level, &t.level->row_spectra(), 2LL * t.base + two_frac, {}});
        Group& group = plan.groups[g];
        PreparedLevel::RowSpectra& v = *group.spectra;
        const std::size_t bins = std::size_t(v.bins);
        Item item{v.row(*t.level, jk), jk};
        if (2LL * t.first + t.count - 1 == two_frac && t.count <= kDirectMaxColumns) {
            // Symmetric about the centre: H(m) = sum over column pairs (p, -p) of their weights
            // times cos(2 pi m p / W), j = 2 |p| indexing the table (the middle column alone).
            item.first_pair = int(plan.pair_weight.size());
            const int half = (t.count + 1) / 2;
            for (int d = 0; d < half; ++d) {
                const int mirror = t.count - 1 - d;
                plan.pair_weight.push_back(t.omega *
                                           (mirror == d ? w[std::size_t(d)] : w[std::size_t(d)] + w[std::size_t(mirror)]));
                const long long j = std::llabs(2LL * (t.first + d) - two_frac);
                plan.pair_row.push_back(v.cos_table.data() + std::size_t(j) * bins);
            }
            item.pairs = half;
        } else {
            // The kernel's own transform: S(m) = sum_e K[e] e^{-2 pi i m e / W} with K at the
            // columns first + d (mod W); H(m) = e^{-2 pi i m frac / W} conj(S(m)), and
            // e^{-2 pi i m frac / W} = conj(turns[m * 2 frac]).
            kernel.assign(std::size_t(v.width), 0.0);
            for (int d = 0; d < t.count; ++d) {
                int e = (t.first + d) % v.width;
                if (e < 0) e += v.width;
                kernel[std::size_t(e)] += w[std::size_t(d)];
            }
            kernel_spectrum.resize(bins);
            v.plan.forward(kernel.data(), kernel_spectrum.data());
            item.kernel = std::ptrdiff_t(plan.kernels.size());
            plan.kernels.resize(plan.kernels.size() + 2 * bins);
            double* h = plan.kernels.data() + item.kernel;
            for (std::size_t m = 0; m < bins; ++m) {
                const Complex hm = t.omega * std::conj(v.turns[m * std::size_t(two_frac)] * kernel_spectrum[m]);
                h[m] = hm.real();
                h[bins + m] = hm.imag();
            }
        }
        group.items.push_back(item);
    }
}

bool FourierFirstPass::Impl::mirrored(const FourierRowPlan& plan, const FourierRowPlan& mirror) const {
    // Of the kernel's largest weight (or spectrum value): mirrored weights are equal but for the
    // rounding of their cosines (a few ulps), which the power n multiplies.
    const double same = 1e-12 + 8.0 * summer.shininess() * std::numeric_limits<double>::epsilon();
    if (plan.groups.size() != mirror.groups.size()) return false;
    const int last_row = summer.level().height() - 1;
    for (std::size_t g = 0; g < plan.groups.size(); ++g) {
        const FourierRowPlan::Group& a = plan.groups[g];
        const std::size_t k_b = mirror.group_index(a.level);
        if (k_b == mirror.groups.size()) return false;
        const FourierRowPlan::Group& b = mirror.groups[k_b];
        if (b.items.size() != a.items.size() || b.two_centre != a.two_centre) return false;
        const std::size_t count = a.items.size(), bins = std::size_t(a.spectra->bins);
        for (std::size_t k = 0; k < count; ++k) {
            const FourierRowPlan::Item& x = a.items[k];
            const FourierRowPlan::Item& y = b.items[count - 1 - k];  // ascending rows, mirrored
            if (y.jk != last_row - x.jk || (x.kernel < 0) != (y.kernel < 0)) return false;
            if (x.kernel < 0) {
                if (x.pairs != y.pairs) return false;
                const double largest =
                    largest_magnitude(plan.pair_weight.data() + x.first_pair, std::size_t(x.pairs));
                for (int p = 0; p < x.pairs; ++p) {
                    const std::size_t i = std::size_t(x.first_pair + p), j = std::size_t(y.first_pair + p);
                    if (plan.pair_row[i] != mirror.pair_row[j] ||
                        std::abs(plan.pair_weight[i] - mirror.pair_weight[j]) > same * largest)
                        return false;
                }
            } else {
                const double* hx = plan.kernels.data() + x.kernel;
                const double* hy = mirror.kernels.data() + y.kernel;
                const double largest = largest_magnitude(hx, 2 * bins);
                for (std::size_t m = 0; m < 2 * bins; ++m)
                    if (std::abs(hx[m] - hy[m]) > same * largest) return false;
            }
        }
    }
    return true;
}

namespace {

// A(m) = sum over the group's rows of omega H(m) F(m) for one output row (Rows = 1) or for it
// and its mirror (Rows = 2, the mirror's rows in reverse order, the same H), bins in blocks
// held in registers while every row is added. a[r]: channel c's real parts at 2 c bins,
// imaginary parts after.
template <int Rows>
void accumulate_group(const FourierRowPlan& plan, const FourierRowPlan::Group& g,
                      const FourierRowPlan::Group* mirror, double* const* a) {
    // kBlocks blocks of bins per pass for two rows too (24 accumulators; the compiler keeps
    // most in registers): one block for two rows, with four chains for H, was 4 % slower than
    // the one-row pass (2026-12-07, n = 5120 at 512x256), its loads twice as many streams of
    // half the length.
    constexpr std::size_t kRowBlocks = kBlocks;
    constexpr std::size_t kStep = kLanes * kRowBlocks;
    // Independent chains of multiply-adds for H: one would wait on the previous result (~4
    // cycles) at every pair.
    constexpr int kChains = 2;
    const std::size_t bins = std::size_t(g.spectra->bins);
    const std::size_t count = g.items.size();
    const auto spectra_of = [&](std::size_t k, int r) {
        return r == 0 ? g.items[k].spectra : mirror->items[count - 1 - k].spectra;
    };
    std::size_t m0 = 0;
    for (; m0 + kStep <= bins; m0 += kStep) {
        DoubleBlock acc[Rows][3][2][kRowBlocks] = {};
        for (std::size_t k = 0; k < count; ++k) {
            const FourierRowPlan::Item& item = g.items[k];
            DoubleBlock hr[kRowBlocks] = {}, hi[kRowBlocks] = {};
            bool complex_h = false;
            if (item.kernel < 0) {
                DoubleBlock chain[kChains][kRowBlocks] = {};
                const int end = item.first_pair + item.pairs;
                int p = item.first_pair;
                for (; p + kChains <= end; p += kChains)
                    for (int c = 0; c < kChains; ++c) {
                        const double wp = plan.pair_weight[std::size_t(p + c)];
                        const double* row = plan.pair_row[std::size_t(p + c)] + m0;
                        for (std::size_t b = 0; b < kRowBlocks; ++b) chain[c][b] += wp * load(row + b * kLanes);
                    }
                for (; p < end; ++p) {
                    const double wp = plan.pair_weight[std::size_t(p)];
                    const double* row = plan.pair_row[std::size_t(p)] + m0;
                    for (std::size_t b = 0; b < kRowBlocks; ++b) chain[0][b] += wp * load(row + b * kLanes);
                }
                for (std::size_t b = 0; b < kRowBlocks; ++b) {
                    hr[b] = chain[0][b];
                    for (int c = 1; c < kChains; ++c) hr[b] += chain[c][b];
                }
            } else {
                const double* h = plan.kernels.data() + item.kernel + m0;
                for (std::size_t b = 0; b < kRowBlocks; ++b) {
                    hr[b] = load(h + b * kLanes);
                    hi[b] = load(h + bins + b * kLanes);
                }
                complex_h = true;
            }
            for (int r = 0; r < Rows; ++r) {
                const double* spectra = spectra_of(k, r);
                for (int c = 0; c < 3; ++c) {
                    const double* fr = spectra + 2 * std::size_t(c) * bins + m0;
                    const double* fi = fr + bins;
                    for (std::size_t b = 0; b < kRowBlocks; ++b) {
                        const DoubleBlock re = load(fr + b * kLanes), im = load(fi + b * kLanes);
                        acc[r][c][0][b] += hr[b] * re;
                        acc[r][c][1][b] += hr[b] * im;
                        if (complex_h) {
                            acc[r][c][0][b] -= hi[b] * im;
                            acc[r][c][1][b] += hi[b] * re;
                        }
                    }
                }
            }
        }
        for (int r = 0; r < Rows; ++r)
            for (int c = 0; c < 3; ++c)
                for (std::size_t b = 0; b < kRowBlocks; ++b) {
                    store(a[r] + 2 * std::size_t(c) * bins + m0 + b * kLanes, acc[r][c][0][b]);
                    store(a[r] + (2 * std::size_t(c) + 1) * bins + m0 + b * kLanes, acc[r][c][1][b]);
                }
    }
    for (std::size_t m = m0; m < bins; ++m) {  // the last bins (W/2 + 1 is odd)
        double acc[Rows][3][2] = {};
        for (std::size_t k = 0; k < count; ++k) {
            const FourierRowPlan::Item& item = g.items[k];
            double hr = 0, hi = 0;
            if (item.kernel < 0) {
                for (int p = item.first_pair; p < item.first_pair + item.pairs; ++p)
                    hr += plan.pair_weight[std::size_t(p)] * plan.pair_row[std::size_t(p)][m];
            } else {
                hr = plan.kernels[std::size_t(item.kernel) + m];
                hi = plan.kernels[std::size_t(item.kernel) + bins + m];
            }
            for (int r = 0; r < Rows; ++r) {
                const double* spectra = spectra_of(k, r);
                for (int c = 0; c < 3; ++c) {
                    const double re = spectra[2 * std::size_t(c) * bins + m];
                    const double im = spectra[(2 * std::size_t(c) + 1) * bins + m];
                    acc[r][c][0] += hr * re - hi * im;
                    acc[r][c][1] += hr * im + hi * re;
                }
            }
        }
        for (int r = 0; r < Rows; ++r)
            for (int c = 0; c < 3; ++c) {
                a[r][2 * std::size_t(c) * bins + m] = acc[r][c][0];
                a[r][(2 * std::size_t(c) + 1) * bins + m] = acc[r][c][1];
            }
    }
}

}  // namespace

void FourierFirstPass::Impl::sum(int row, const FourierRowPlan& plan, int mirror_row, const FourierRowPlan* mirror,
                                 LobeSums& sums) const {
    const int rows = mirror ? 2 : 1;
    const int out_rows[2] = {row, mirror_row};
    // Whole stored rows (run()'s contract): the row's texels are consecutive from its column 0.
    for (int r = 0; r < rows; ++r)
        if (!sums.stored(out_rows[r]) || sums.first_column(out_rows[r]) != 0 || sums.end_column(out_rows[r]) != out_w)
            throw RuntimeError("internal: the Fourier first pass writes whole stored rows of sums");

    // Per group, A(m) (accumulate_group); then the bins folded modulo out_w (the centre's phase
    // applied) into one spectrum per channel, and one inverse transform each.
    const int out_bins = out_w / 2 + 1;
    std::vector<Complex> folded(std::size_t(rows) * 3 * std::size_t(out_bins));
    std::vector<double> a_values;
    for (const FourierRowPlan::Group& g : plan.groups) {
        const PreparedLevel::RowSpectra& v = *g.spectra;
        const std::size_t bins = std::size_t(v.bins);
        a_values.resize(std::size_t(rows) * 6 * bins);
        double* a[2] = {a_values.data(), a_values.data() + 6 * bins};
        if (mirror) {
            accumulate_group<2>(plan, g, &mirror->groups[mirror->group_index(g.level)], a);  // matched by mirrored()
        } else {
            accumulate_group<1>(plan, g, nullptr, a);
        }

        // Y(m) = A(m) e^{i pi m (2 c_0) / W} / W for m <= W/2, and Y(W - m) = conj(Y(m))
        // above (the sums are real); bin m adds to folded bin m mod out_w.
        const std::size_t period = v.turns.size();
        const std::size_t centre_step = std::size_t(((g.two_centre % (long long)period) + (long long)period) %
                                                    (long long)period);
        const double scale = 1.0 / v.width;
        std::size_t index = 0;  // m * centre_step mod period
        for (std::size_t m = 0; m < bins; ++m) {
            const Complex phase = v.turns[index] * scale;
            index += centre_step;
            if (index >= period) index -= period;
            // m and W - m fold to m mod out_w and (W - m) mod out_w = out_w - m mod out_w (a
            // power of two: a mask, not a division per bin).
            const std::size_t fold = std::size_t(out_w) - 1;
            const std::size_t low = m & fold;
            const std::size_t high = (std::size_t(v.width) - m) & fold;
            for (int r = 0; r < rows; ++r)
                for (int c = 0; c < 3; ++c) {
                    const Complex y = Complex(a[r][2 * std::size_t(c) * bins + m], a[r][(2 * std::size_t(c) + 1) * bins + m]) * phase;
                    Complex* z = folded.data() + (std::size_t(r) * 3 + std::size_t(c)) * std::size_t(out_bins);
                    if (low < std::size_t(out_bins)) z[low] += y;
                    // W - m is another bin unless m is 0 or W/2; it holds conj(y).
                    if (m != 0 && m != bins - 1 && high < std::size_t(out_bins)) z[high] += std::conj(y);
                }
        }
    }
    // The transforms round to ~1e-16 of the row's largest sums (times a few log2 W), where the
    // direct sums of non-negative terms round to each texel's own: a texel whose true sum is 0
    // (a black region the lobe sees alone) comes back as +-1e-16 of its row's. Values within
    // kNoise of the row's largest are taken as 0: the error metric's floor (the map's mean)
    // is far above that, and the cone's bound then treats the texel as the direct sums would.
    // Per channel: each has its own transforms.
    constexpr double kNoise = 1e-12;
    std::vector<double> values(3 * static_cast<std::size_t>(out_w));  // channel c at c out_w
    for (int r = 0; r < rows; ++r) {
        const Complex* spectra[3];
        double* channel[3];
        for (int c = 0; c < 3; ++c) {
            spectra[c] = folded.data() + (std::size_t(r) * 3 + std::size_t(c)) * std::size_t(out_bins);
            channel[c] = values.data() + std::size_t(c) * std::size_t(out_w);
        }
        out_plan.inverse_batch(spectra, channel, 3);  // the three channels in vector lanes
        double* out = sums.num.data() + sums.texel(out_rows[r], 0) * 3;
        for (int c = 0; c < 3; ++c) {
            const double largest = largest_magnitude(channel[c], std::size_t(out_w));
            for (int q = 0; q < out_w; ++q) {
                const double x = channel[c][q];
                out[3 * std::size_t(q) + std::size_t(c)] = std::abs(x) <= kNoise * largest ? 0.0 : x;
            }
        }
        const FourierRowPlan& p = r == 0 ? plan : *mirror;
        sums.den[std::size_t(out_rows[r])] = p.den;
        sums.cmax[std::size_t(out_rows[r])] = p.cmax;
    }
}

int FourierFirstPass::run(const std::vector<int>& rows, double c0, LobeSums& sums, const RowProgress& progress) const {
    // Output rows mirrored about the equator read the level's rows mirrored with the same
    // weights (a Phong weight depends on the two rows' cosines through their product), so a
    // row and its mirror, when both are asked, take one pass: the kernels' spectra, two thirds
    // of the pass's multiply-adds, serve both (where merged polar columns or rounding make the
    // two rows' terms differ, each is summed on its own).
    const int out_h = impl_->summer.out_height();
    std::vector<char> asked(std::size_t(out_h), 0);
    for (int r : rows) asked[std::size_t(r)] = 1;
    std::vector<std::pair<int, int>> tasks;  // (row, its mirror or -1)
    for (int r : rows) {
        const int m = out_h - 1 - r;
        if (m > r && asked[std::size_t(m)])
            tasks.emplace_back(r, m);
        else if (!(m < r && asked[std::size_t(m)]))
            tasks.emplace_back(r, -1);
    }
    std::atomic<int> shared{0};
    parallel_for(int(tasks.size()), impl_->threads, [&](int k) {
        const auto [row, mirror_row] = tasks[std::size_t(k)];
        FourierRowPlan plan;
        impl_->plan_row(row, c0, plan);
        if (mirror_row < 0) {
            impl_->sum(row, plan, -1, nullptr, sums);
        } else {
            FourierRowPlan mirror;
            impl_->plan_row(mirror_row, c0, mirror);
            if (impl_->mirrored(plan, mirror)) {
                impl_->sum(row, plan, mirror_row, &mirror, sums);
                shared += 2;
            } else {
                impl_->sum(row, plan, -1, nullptr, sums);
                impl_->sum(mirror_row, mirror, -1, nullptr, sums);
            }
        }
        if (progress) progress(mirror_row < 0 ? 1 : 2);
    });
    return shared.load();
}

}  // namespace glint::convolution
