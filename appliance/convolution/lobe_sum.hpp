// The shared inner loop of the exact and cone methods: for every output texel r
// of an equirect grid, the sums of the conventions
//
//   num(r) = sum_k w_k(r) L_k dOmega_k,   den(r) = sum_k w_k(r) dOmega_k,
//   w_k(r) = (max(0, r.w_k) / cmax(r))^n
//
// over the texels k of one input level whose cosine r.w_k is at least a cut-off
// c_min (c_min = 0 keeps every non-zero term). Dividing by cmax(r), the largest
// cosine between r and any texel centre of the level, makes the largest weight
// ~1 so the weights never underflow to 0/0 (n = 20480 on an 8x4 map works).
//
// Why it is fast without approximation: on an equirect grid the cosine between
// an output texel centre and an input texel centre is
//     r.w = sin(tr) sin(tk) cos(phi_k - phi_r) + cos(tr) cos(tk),
// which for a fixed (output row, input row) depends only on the column offset.
// Output columns fall into C = W'/gcd(W, W') phase classes; within a class the
// weight vector over column offsets is the same for every output column, so it
// is computed once and the work left is pure multiply-adds. Rows are bounded by
// the cut-off cone analytically (per input row, |dphi| <= acos((c_min - b)/a)),
// which is exact at both poles (a -> 0) and across the seam (indices wrap).
#pragma once

#include <functional>
#include <limits>
#include <map>
#include <memory>
#include <mutex>
#include <utility>
#include <vector>

#include "appliance/core/buffer.hpp"
#include "appliance/core/hdr_image.hpp"

namespace glint::convolution {

class PreparedLevel;

// sum over texels of max(R, G, B) * dOmega: an upper bound on every channel's
// radiant power (its solid-angle mean is this / 4 pi).
double max_channel_power(const HdrImage& image);
// sum over the texels of one interleaved RGB row of max(R, G, B).
double max_channel_row_sum(const float* rgb, int width);

// Largest radiance (any channel) of a level over spherical caps of one radius:
// an upper bound, since every texel that meets the cap counts. Rows are grouped
// in fixed blocks of about the radius (aligned in theta only); within a block,
// column ranges are answered exactly by a cyclic sparse table, so the answer
// does not depend on where the columns start: rotating the map by whole
// columns rotates the answers (the cone's results stay rotation-equivariant).
class CapMax {
public:
    CapMax(const PreparedLevel& level, double radius, int threads = 1);

    // The rows and azimuth half-width of the caps centred at polar angle theta
    // (one per output row: the asin is not repeated per texel).
    struct Band {
        int first_block = 0, last_block = 0;
        bool whole_rows = true;     // the cap holds a pole: every column counts
        double half_width = 0;      // azimuth half-width of the cap, rad
    };
    Band band(double theta) const;
    // Maximum over the cap of the radius around (theta, phi) of band(theta).
    double query(const Band& band, double phi) const;
    double query(double theta, double phi) const { return query(band(theta), phi); }
    // Largest radiance over the whole rows of a band: a bound on every query of it.
    double band_max(const Band& band) const;

private:
    int width_, height_, block_rows_, blocks_, levels_;
    double radius_;
    // table_[(k * blocks_ + b) * width_ + i]: max over the rows of block b and
    // the columns i, i+1, ..., i + 2^k - 1 (cyclic).
    UninitVector<float> table_;  // every value written by the constructor
    std::vector<float> block_max_;  // per block: the largest value of its rows
    float range_max(int block, int first, int count) const;
};

// An input level laid out for the kernel: one plane per channel and row, the
// row's geometry, and (on demand) the phase-split layout of LobeSummer.
class PreparedLevel {
public:
    // threads: for the layout work here and in phases().
    explicit PreparedLevel(const HdrImage& level, int threads = 1);
    // `parent` with every m adjacent columns averaged (see merged_columns).
    // (Made without rows: merged_columns builds the rows asked for, ensure_rows.)
    PreparedLevel(const PreparedLevel& parent, int m);
    int width() const { return width_; }
    int height() const { return height_; }
    double cos_theta(int j) const { return cos_t_[std::size_t(j)]; }
    double sin_theta(int j) const { return sin_t_[std::size_t(j)]; }
    double solid_angle(int j) const { return omega_[std::size_t(j)]; }
    // Channel c of row j, columns [0, width).
    const float* plane(int j, int c) const {
        return planes_.data() + (std::size_t(j) * 3 + std::size_t(c)) * std::size_t(width_);
    }
    float max_value() const { return max_value_; }
    // sum over texels of max(R, G, B) * dOmega: an upper bound on every channel's power.
    double power() const { return power_; }

    // The rows split by column phase for `step` (see LobeSummer): phase s of row
    // j holds L[(t * step + s) mod W] for t in [0, 2 * per_class), and phase rows
    // are phase_stride(per_class) floats apart. Built on first use and kept,
    // since every map of one output width needs the same layout.
    const UninitVector<float>& phases(int step, int per_class) const;
    // The same for the rows flagged in `rows` (per level row): the others may be unwritten.
    const UninitVector<float>& phases(int step, int per_class, const std::vector<char>& rows) const;
    // The level with every m adjacent columns averaged (m divides the width):
    // texels of one row share a solid angle, so the average is energy
    // preserving. Built on first use and kept.
    const PreparedLevel& merged_columns(int m) const;
    // The same with only the rows flagged in `rows` (per level row) sure to be made: a narrow
    // lobe merges columns only in the rows near the poles.
    const PreparedLevel& merged_columns(int m, const std::vector<char>& rows) const;
    // 2 * per_class plus one cache line: a narrow lobe's terms all read the same
    // columns of ~20 rows x 3 channels, and a stride of a multiple of 4 KiB would
    // put all of those reads into the same few L1 sets.
    static std::size_t phase_stride(int per_class) { return 2 * std::size_t(per_class) + 16; }

    // The spectra of the rows for the Fourier first pass (fourier_pass.cpp, which defines
    // both): made row by row on first use and kept, so that every map read from this level
    // shares them.
    struct RowSpectra;
    RowSpectra& row_spectra() const;
    // Row j's spectra (made now if not yet): per channel W/2 + 1 real parts, then the imaginary
    // parts, of X[k] = sum_i L_i e^(-2 pi i i k / W).
    const double* row_spectrum(int j) const;
    // Makes rows [first, first + count) of a version with merged columns (which makes only the
    // rows its readers flag) if they are not made yet; nothing for a level made from an image.
    void make_rows(int first, int count) const;
    // Frees what was built on demand (phase layouts, merged versions, row spectra): they are
    // made again if read later (a LobeSummer lays out every row of each merge factor it reads).
    // Only while nothing reads them (no LobeSummer or Fourier pass of this level alive): the
    // engine calls it when a map that was the level's last reader has summed its grid, so that a
    // narrow lobe's large grid does not keep two copies of the level through its delivery.
    void release_layouts() const;
    // How many of those are held now: phase layouts, merged versions, and the row spectra (0 or 1).
    std::size_t layouts_held() const;

private:
    int width_, height_, threads_;
    std::vector<double> cos_t_, sin_t_, omega_;
    // Every value written by the constructor; a merged version's rows by ensure_rows (lazily, from
    // const methods, under rows_mutex_).
    mutable UninitVector<float> planes_;
    float max_value_ = 0;
    double power_ = 0;
    mutable std::mutex phases_mutex_;  // guards the lazily built layouts below
    // The padding past each phase row's 2 * per_class values is never read.
    struct PhaseLayout {
        UninitVector<float> values;
        std::vector<char> built;  // per level row: laid out
    };
    mutable std::map<std::pair<int, int>, PhaseLayout> phases_;
    // A merged version: the level it averages, m, and which of its rows are made so far.
    const PreparedLevel* parent_ = nullptr;
    int merge_ = 1;
    mutable std::vector<char> built_;
    mutable std::mutex rows_mutex_;
    // Makes the flagged rows not made yet (a merged version; the parent's first).
    void ensure_rows(const std::vector<char>& rows) const;
    mutable std::mutex merged_mutex_;
    mutable std::map<int, std::unique_ptr<PreparedLevel>> merged_;
    mutable std::mutex spectra_mutex_;
    mutable std::shared_ptr<RowSpectra> spectra_;
};

// Per-texel partial sums for an output grid of out_w x out_h.
struct LobeSums {
    int out_w = 0, out_h = 0, classes = 0;
    // 3 per output texel of the rows stored; not zeroed: sum_row writes the
    // texels it sums, and only those may be read.
    UninitVector<double> num;
    // Rows stored in num: slot[row] is a row's place (-1: not stored); empty
    // when every row is, in order. A few rows of a fine grid (the exact patches)
    // then take memory for those rows only.
    std::vector<int> slot;
    // Stored rows may also keep only a window of columns [col_lo, col_hi) per slot, starting at
    // row_start in num (empty: whole rows). The exact patches of a fine grid ask for a few
    // texels of a 4096-wide row: whole rows cost 4-5x the memory, and fresh memory is slow to
    // fault in. Only the window's texels may be addressed.
    std::vector<std::size_t> row_start;
    std::vector<int> col_lo, col_hi;
    std::size_t texel(int row, int col) const {
        const std::size_t r = slot.empty() ? std::size_t(row) : std::size_t(slot[std::size_t(row)]);
        if (!col_lo.empty()) return row_start[r] + std::size_t(col - col_lo[r]);
        return r * std::size_t(out_w) + std::size_t(col);
    }
    // The columns of a stored row that may be addressed, [first_column, end_column).
    int first_column(int row) const { return col_lo.empty() ? 0 : col_lo[std::size_t(slot[std::size_t(row)])]; }
    int end_column(int row) const { return col_hi.empty() ? out_w : col_hi[std::size_t(slot[std::size_t(row)])]; }
    bool stored(int row) const { return slot.empty() || slot[std::size_t(row)] >= 0; }
    std::vector<double> den;   // per (output row, class)
    std::vector<double> cmax;  // per (output row, class)
    int class_of(int column) const { return column % classes; }
};

// How the multiply-adds are accumulated. Double: every one in double (the
// exact method). FloatRuns: runs of 32 terms in float, each run's sum added to
// double accumulators (the cone method; lobe_sum.cpp has the error bound).
enum class Accumulation { Double, FloatRuns };

// Rows near the poles may read the level with merged columns. Near a pole an
// equirect row's texels are narrow in azimuth (sin(theta) 2 pi / W of arc),
// and a lobe there covers many more of them than at the equator: with the
// output rows evenly spaced in theta, three quarters of a narrow lobe's terms
// fall in the rows with sin(theta) < 1/2. Merging m columns of such a row is
// a coarser level in azimuth only; the planner allows it up to the arc its
// level error model accepts for the lobe (merged_arc_budget in planner.hpp).
// The merge factor of level row j: the largest power of two m <= 64 whose
// merged texels, at the row's edge nearer the equator, span at most max_arc
// radians of arc, that divides the width and keeps the output's column classes
// (gcd(W / m, out_w) = gcd(W, out_w)); 1 when none.
int polar_merge_factor(int row, int level_width, int level_height, int out_width, double max_arc);
// The widest merged texel (radians of arc) of any row; 0 when no row merges.
double widest_merged_arc(int level_width, int level_height, int out_width, double max_arc);
// The merge factor of every row of `level`: polar_merge_factor, lowered where the row's values
// are rough. The arc budget above is the level model's, for smooth radiance (the error of
// a group's mean is second order in its arc); a group of unlike values errs to first order:
// by the lobe's change across the group (up to 0.61 sqrt(n) times the arc, relative to its
// peak) times the values' spread about their mean. So the merged arc times the row's roughness
// (over the groups and channels, the largest sum |L - mean| / (sum L + m L_mean), L_mean the
// level's mean radiance) stays within max_arc_roughness. Log-normal noise (neighbours 50x
// apart) erred 7-8 % at its worst texel merged (n = 8e3 ... 3e4, 512x256 to 256x128), 1e-4 not.
std::vector<int> polar_merge_factors(const PreparedLevel& level, int out_width, double max_arc,
                                     double max_arc_roughness);

class LobeSummer {
public:
    // max_merged_arc > 0: rows near the poles read merged columns (above), within
    // max_arc_roughness where their values are rough (polar_merge_factors); 0 for `exact`.
    LobeSummer(const PreparedLevel& level, int out_w, int out_h, double shininess,
               Accumulation accumulation = Accumulation::Double, double max_merged_arc = 0,
               double max_arc_roughness = std::numeric_limits<double>::infinity());
    // Not copied: a geometry's lazily made phase layout (phases_of) is published through the
    // summer's own Geometry.
    LobeSummer(const LobeSummer&) = delete;
    LobeSummer& operator=(const LobeSummer&) = delete;

    // Fills sums for one output row with the cosine cut-off c_min (0 = every
    // non-zero term). With `columns` (half-open [first, last) column runs), only
    // those texels' numerators are summed (the row's denominators always are);
    // numerators of nearby columns may be written too.
    // Thread-safe across rows.
    using ColumnRuns = std::vector<std::pair<int, int>>;
    // With c_inner <= 1, the terms whose cosine reaches max(c_inner, the
    // underflow cosine) are left out: the annulus between two cut-offs, added
    // by the caller to the sums of a pass with c_min = c_inner.
    void sum_row(int out_row, double c_min, LobeSums& sums, const ColumnRuns* columns = nullptr,
                 double c_inner = 2.0) const;
    // Sums for every output row, or (rows given) for those rows only, and (columns given: one
    // list per row of `rows`, distinct rows) only the columns that sum_row with those runs
    // writes.
    LobeSums make_sums(const std::vector<int>* rows = nullptr, const std::vector<ColumnRuns>* columns = nullptr) const;

    // Largest cosine between the direction of output texel (row, class) and any
    // texel centre of the level.
    double cmax(int out_row, int cls) const;
    // Cosine below which a weight relative to the largest is under the smallest
    // normal double (2.2e-308): such terms cannot change a double sum.
    double underflow_cos(double cmax_value) const;

    int classes() const { return classes_; }
    int out_height() const { return out_h_; }
    double shininess() const { return n_; }
    // Per level row, the merge factor it is read with (polar_merge_factors; 1: the level).
    const std::vector<int>& merge_factors() const { return merge_factors_; }
    const PreparedLevel& level() const { return level_; }

    // Builds the phase layouts sum_row reads (with the level's threads). sum_row builds them
    // itself when they are missing, but inside a parallel loop that is one thread's work.
    void lay_out() const;

    // What sum_row's first pass (c_inner > 1) reads, for a caller that sums the same terms
    // another way (the Fourier first pass, fourier_pass.cpp).
    // The level rows read for output row out_row, class cls, with cut-off c_min: [first, last]
    // (none when last < first), and the largest cosine cmax(out_row, cls) the weights divide by.
    struct RowWindow {
        int first = 0, last = -1;
        double cmax = 1, lowest_cos = 0;  // lowest_cos: max(c_min, underflow_cos(cmax))
    };
    RowWindow window(int out_row, int cls, double c_min) const;
    // The terms of level row jk in `window`: the texels of geometry `level` (the level itself
    // or a version with merged columns) at columns base + q * step + first + d, d in
    // [0, count), for output column q * classes + cls, weighted w[d] * omega (w written to
    // w[0..count), count <= level->width()). An output column's centre sits at column
    // base + frac + q * step of that version.
    struct RowTerms {
        const PreparedLevel* level = nullptr;
        int base = 0, step = 1, first = 0, count = 0;
        double frac = 0, omega = 0;
    };
    RowTerms row_terms(int out_row, int cls, const RowWindow& window, int jk, double* w) const;

private:
    // One weight and the red texel run it multiplies (green and blue follow at
    // fixed strides in the phase layout).
    struct Term {
        double weight;
        const float* texels;
    };
    static constexpr std::size_t kTermChunk = 2048;  // terms applied per pass (fit in L1/L2)
    // How the output columns meet the columns of one version of the level (the
    // level itself, or it with merged columns): every version has the same
    // classes and per_class, so their terms add into the same accumulators.
    struct Geometry {
        const PreparedLevel* level = nullptr;
        int width = 0, step = 0;
        std::vector<int> base;     // per class: level column at or left of the output centre
        std::vector<double> frac;  // per class: offset of the output centre from base, in columns
        // cos(dphi) per class for column offsets d in [-cos_offset, width + cos_offset).
        std::vector<double> cos_dphi;
        int cos_offset = 0;
        std::size_t cos_stride = 0;
        // The rows split by column phase for this output width
        // (PreparedLevel::phases): the texels that one weight multiplies across a
        // whole class are contiguous. Laid out on first use (lay_out): the Fourier first pass
        // (fourier_pass.cpp) reads the level's planes and never needs them.
        std::vector<char> rows;  // the level rows read with this geometry
        std::shared_ptr<std::once_flag> laid_out;
        mutable const UninitVector<float>* phases = nullptr;
    };
    // The geometry of `level` (or a merged version of it) for the level rows flagged in `rows`.
    Geometry make_geometry(const PreparedLevel& level, const std::vector<char>& rows) const;
    const float* phase(const Geometry& g, int row, int s) const {
        return g.phases->data() +
               (std::size_t(row) * 3 * std::size_t(g.step) + std::size_t(s)) * PreparedLevel::phase_stride(per_class_);
    }
    // The runs of class cls's column indices q (column = q * classes + cls) that sum_row computes
    // for the column runs `columns`: widened to whole blocks of the vector path.
    ColumnRuns class_runs(int cls, const ColumnRuns& columns) const;
    void flush_terms(const std::vector<Term>& terms, const ColumnRuns& q_runs, std::size_t channel_stride,
                     double* acc_r, double* acc_g, double* acc_b) const;
    // Fills w[0..count) with the weights of cosines a * cos(dphi_d) + b, where
    // dphi_d is the azimuth offset of column d_lo + d of geometry g in class cls.
    void weights(const Geometry& g, int cls, int d_lo, int count, double a, double b, double inv_cmax,
                 double* w) const;
    // Columns [d_lo, d_lo + count) of a level row whose cosine a * cos(dphi) + b with class
    // cls's texels is at least `bound` (count 0: none). The inner cone of an annulus uses the
    // same arithmetic, so its columns are exactly those of the pass that summed it.
    void columns_above(const Geometry& g, int cls, double bound, double a, double b, int& d_lo, int& count) const;
    const UninitVector<float>& phases_of(const Geometry& g) const;

    const PreparedLevel& level_;
    int out_w_, out_h_;
    double n_;
    Accumulation accumulation_;
    int classes_, per_class_;
    std::vector<double> out_cos_t_, out_sin_t_;
    std::vector<Geometry> geometries_;  // [0]: the level; then merged versions
    std::vector<int> merge_factors_;    // per level row: its merge factor
    std::vector<int> row_geometry_;     // per level row: the geometry it is read with
};

// x[d] = x[d]^n for x[d] >= 0 (0 stays 0, also for n = 0: only r.w > 0 counts).
// Integer n by binary exponentiation in vectorised passes, else std::pow.
void raise_to_power(double* x, int count, double n);

// Output = num / den per texel (as float).
HdrImage finish_sums(const LobeSums& sums);

}  // namespace glint::convolution
