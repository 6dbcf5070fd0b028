// The individual convolution methods behind convolve() (convolution.hpp).
// Each computes one map; the planner (planner.hpp) decides which runs and how.
#pragma once

#include <functional>
#include <memory>
#include <vector>

#include "appliance/convolution/convolution.hpp"
#include "appliance/convolution/lobe_sum.hpp"
#include "appliance/core/hdr_image.hpp"

namespace glint::convolution {

using RowProgress = std::function<void(long long rows)>;

// `exact`: the sums of the conventions over every input texel (the paper's
// method), double accumulation, all cores. Skips only terms that are zero
// (r.w <= 0) or whose weight relative to the largest is below the smallest
// normal double, which cannot change a double sum.
HdrImage exact_convolve(const PreparedLevel& input, double shininess, Size out, int threads,
                        const RowProgress& progress);

// The few brightest input texels, taken out of the map and summed exactly at
// full resolution for every output texel. Without this, a cut-off by lobe
// energy alone cannot bound the error of a dark texel next to a sun, and a
// coarse pyramid level would move the sun to the centre of its coarse texel.
struct BrightTexel {
    double x = 0, y = 0, z = 0;  // direction
    double theta = 0, phi = 0;
    double r = 0, g = 0, b = 0;  // radiance * solid angle
};
struct BrightSplit {
    std::vector<BrightTexel> texels;
    HdrImage remainder;          // the input with those texels set to 0
    double threshold = 0;        // max channel above which a texel counted as bright
    // max_channel_power(remainder), summed the same way (rows in order; equal up to the rounding
    // of a multiply-add a compiler fuses), without a pass of its own.
    double remainder_power = 0;
};
// Texels whose largest channel exceeds `contrast` times the solid-angle mean of
// the map, brightest first, at most max_count of them.
// The remainder is `input` itself with those texels zeroed: taken over when moved in, else
// copied row by row in the threads' first pass over the rows (a copy of 1024x512 was 5 % of a
// single 128x64 map's time, on one thread before the pass).
BrightSplit split_bright(HdrImage&& input, double contrast, int max_count, int threads = 1);
BrightSplit split_bright(const HdrImage& input, double contrast, int max_count, int threads = 1);

// Bright texels of a lobe of shininess n >= 2, with cells of the sphere (a quadtree of equirect
// cells, coarsest first) replaced by one term where that is within the error allowed: the
// cell's energy per channel times mu^n, in the direction of its energy-weighted mean direction
// m (mu = |m|), which is the cell's exact sum wherever every member's cosine is positive, to
// second order. Where r.m = mu cos(alpha), the members' terms minus the cell's are
//   g'(r.m) r.v + 1/2 sum_k L_k g''(xi_k) (r.(d_k - m))^2,  g(c) = max(c, 0)^n,
// (v: each channel's first moment minus its energy times m, zero for a cell of one colour), and
// |r.(d_k - m)| <= |cos beta_k - mu| + sin(alpha) |e.t_k| (beta_k: member k's angle from m, t_k
// its part across m, e the unit tangent towards r), whose energy-weighted squares are bounded by
// the largest eigenvalue of the t_k's second moments. A cell is merged when that bound,
// evaluated over alpha in steps with the largest cosine and sine of each step, stays within
// `relative` times the merged term plus `absolute` times the cell's share (each channel's
// energy over the sum of all texels' largest channels), in units of L dOmega times weight, at
// every alpha (for the weights max(0, r.w)^n, or those over any positive scale such as
// cmax^n; a clamp min(1, r.w / cmax) would not be covered). The members' terms then differ from the merged ones by at most
// relative x (the merged terms) + absolute at any direction. Fewer than 256 texels, n < 2, or
// members with a negative channel: returned as they are.
std::vector<BrightTexel> merge_bright_cells(const std::vector<BrightTexel>& bright, double shininess,
                                            double relative, double absolute);

// The bright texels' terms (r.w_b / cmax)^n L_b dOmega_b for the output texels
// of an out-sized grid where they are not negligible: the terms dropped at a texel together
// stay below `tolerance` times floor_value (the smallest output), each texel's below its peak's
// share of the bright texels' summed peaks of that; with fewer than 1000 bright texels the
// budget is that many thousandths of `tolerance` (each texel's cut as if it had 1/1000 alone).
// `cmax_floor` is a lower bound of cmax over the grid (the weights are taken relative to it): 1
// where the sums are normalised to the largest weight 1 (add_bright_lobes), so the cut is no
// wider than the tolerance needs. The weight is not clamped at 1: a bright texel nearer the
// output direction than any texel of a coarse level has r.w_b > cmax, and its term is then the
// lobe's own value over the sums' common scale cmax^n, as the remainder's are (a clamp at 1
// biased such terms low by about n (1 - cmax); only a ratio whose power would pass e^80 is
// clamped, so that no weight overflows, in float on the GPU either). Cells of many bright
// texels are merged first (merge_bright_cells) within half the tolerance of their own terms
// plus half the tolerance of floor_value: the bound holds for the lobe's weights over any
// positive scale, and the sums divide that scale out with the rest. Wide lobes over thousands
// of bright texels (a lamp at 8K) need far fewer terms.
class BrightScatter {
public:
    // float_sums: the terms summed in float (each weight rounded to float after its power, in
    // double): for weights up to 1 (cmax_floor 1, BrightLobes), whose sums go into float maps.
    BrightScatter(const std::vector<BrightTexel>& bright, double shininess, Size out, double floor_value,
                  double tolerance, double cmax_floor = 0.999, bool float_sums = false);
    // Adds the terms of output row `row` to nb_row (3 per texel); cmax_row holds
    // `classes` values (column i is class i % classes), ones for sums
    // normalised to the largest weight 1. Thread-safe across rows. With `columns`, only the
    // texels of those half-open column runs (ascending) get their terms; the others are left.
    // nb_row holds the row from column `first_column` on (a window of it; the runs within it).
    void add_row(int row, const double* cmax_row, int classes, double* nb_row,
                 const LobeSummer::ColumnRuns* columns = nullptr, int first_column = 0) const;
    const std::vector<BrightTexel>& texels() const { return bright_; }
    // Per bright texel: the cosine below which its term is dropped (> 1: never used).
    const std::vector<double>& min_cos() const { return min_cos_; }
    double shininess() const { return n_; }
    Size grid() const { return out_; }
    // Per output row, whether some bright texel's cut-off cone may reach it (0: add_row adds
    // nothing there). One pass over the texels' row ranges (a loop over every texel per row
    // took 1.7 % of a 4096x2048 photograph's set: 16384 texels, 4096 rows of fine tiles).
    std::vector<char> rows_reached() const;

private:
    std::vector<BrightTexel> bright_;  // the input's, with cells merged (merge_bright_cells)
    double n_;
    double ratio_cap_;  // the largest r.w / cmax raised to n: e^(80 / n) (1 for n = 0)
    Size out_;
    bool float_sums_ = false;
    std::vector<double> min_cos_, cos_phi_, sin_phi_;
    // Per bright texel: sin(theta_b), and the output rows its cut-off cone can reach (with a
    // row of margin; the exact test is made per row), so a row skips the others cheaply.
    std::vector<double> sin_theta_, cos_phi_b_, sin_phi_b_;
    std::vector<int> first_row_, last_row_;
    // Bright texel k's weights (before the power n) for the columns [i0, end) of a row, into w
    // (a = sin theta_r sin theta_b, bq = cos theta_r cos theta_b).
    void stage_weights(std::size_t k, int i0, int end, double a, double bq, const double* cmax_row, int classes,
                       double* w) const;
    // Bright texels whose weights on every output row are the same up to a shift by whole
    // columns: one polar angle, centres at one phase between output columns. shift[m]: member
    // m's centre column, rounded down; rows: the union of the members' first_row_/last_row_.
    struct Group {
        std::vector<std::size_t> members;
        std::vector<int> shift;
        int first_row = 0, last_row = -1;
    };
    std::vector<Group> groups_;
    // A member's reach on one row: columns [first, first + count), unwrapped (add_row).
    struct Reach {
        std::size_t texel;
        int first, count;
        int shift;
    };
    // For n < 2 (no cells merged there): bright texels of one cell of the sphere, with their
    // centre, angular radius, the sums of L dOmega times (sin theta cos phi, sin theta sin phi,
    // cos theta) per channel (n = 1), of L dOmega (n = 0: every weight in front is 1; and the
    // Taylor series' E for other n), and their moments about the centre (other n).
    struct Cluster {
        std::vector<std::size_t> members;
        double cos_theta = 1, sin_theta = 0, phi = 0, radius = 0;
        double u[3] = {0, 0, 0}, v[3] = {0, 0, 0}, w[3] = {0, 0, 0}, e[3] = {0, 0, 0};
        int first_row = 0, last_row = -1;
        // Per member: its direction's parts, L dOmega per channel (ml[channel][m]) and its cut
        // (cosine >= cut[m]); padded to whole vectors of kMemberLanes by members of no weight
        // (direction 0, radiance 0, cut 2), so add_linear_row sums them in vector lanes.
        static constexpr std::size_t kMemberLanes = 8;
        std::vector<double> mu, mv, mw, ml[3], cut;
        double reach_cos = 2;  // the cosine of the cone around the centre holding every member's cut
        // Fractional n (0 < n < 2, not 1): the centre as a unit (u, v, w), the members' first,
        // second and third moments about it per channel (m1: u v w; m2: uu uv uw vv vw ww; m3: uuu
        // uuv uuw uvv uvw uww vvv vvw vww www, of L dOmega), and the centre's cosine from which the
        // Taylor series holds (> 1: nowhere).
        double centre[3] = {0, 0, 1};
        double m1[3][3] = {}, m2[3][6] = {}, m3[3][10] = {};
        double taylor_cos = 2;
    };
    std::vector<Cluster> clusters_;
    double taylor_kappa_ = 0;  // fractional n: radius / centre's cosine below which the series holds
    // add_row for n < 2: each cluster's sum where every member is in front (linear in the
    // direction for n = 1, constant for n = 0) or, for other n, where its Taylor series holds;
    // its members' terms elsewhere.
    void add_linear_row(int row, double ct, double st, const double* cmax_row, int classes, double* nb_row,
                        const LobeSummer::ColumnRuns* columns, int first_column) const;
    // A run of a row's weights staged for the power n and the sums (add_row).
    struct Staged {
        std::size_t texel;
        int first, count;
        std::size_t offset;
    };
};

struct ConeStats {
    long long refined_texels = 0;  // texels summed again with a wider cone
    double cutoff_energy = 0;      // the first cone's dropped lobe energy, as run (see cone.cpp)
    bool fourier_first_pass = false;  // the first pass was the Fourier one (CPU), else direct sums
};

// The cosine of the cone outside which the lobe of shininess n holds `energy`
// of its energy, e^(1/(n+1)) (0: the hemisphere for energy <= 0). The planner's
// cut-off and cost are this cone's.
double cone_cut_cos(double energy, double shininess);

// `cone`: the lobe sum restricted to the cut-off cone cos t = e^(1/(n+1)) on a
// (solid-angle weighted) pyramid level of the remainder, plus the bright texels
// exactly. After a first pass, each output texel whose error bound
//   |E - E'| <= e * max(Lmax - E', E')   (e: lobe energy outside the cone,
//   Lmax: the largest remainder radiance near the texel, see cone.cpp)
// exceeds texel_tolerance * E' is summed again with a cone that meets it.
// With only_rows, just those output rows are computed (the rest of the image is 0); with
// only_columns too (one list of column runs per row of only_rows), just those texels (the
// CPU sums only them; a backend may sum whole rows). With `into` (an `out`-sized map), the
// texels computed are written into it and an empty image is returned.
// Where the cone's sums are computed: the CPU (the default, LobeSummer) or
// the GPU engine (gpu/). The cone's logic around them (bright cut-offs, the
// per-texel bound, widening, normalisation) is the same for both, except that the CPU sums a
// grid over kConeBandTexels in bands of rows (cone_convolve_in_bands), whose bounds take each
// band's own smallest output: there the two may differ within the tolerance.
class ConeSumsBackend {
public:
    virtual ~ConeSumsBackend() = default;
    // The lobe sums of `rows` inside the cone cos >= c0 (numerators for every
    // texel of those rows; denominators and cmax per row and class).
    virtual LobeSums first_pass(const std::vector<int>& rows, double c0, const RowProgress& progress) = 0;
    // For rows[k]: the sums of the texels in runs[k] over the annulus
    // cut[k] <= cos < c_inner (the first pass's cone, with its arithmetic).
    virtual LobeSums annulus(const std::vector<int>& rows, const std::vector<LobeSummer::ColumnRuns>& runs,
                             const std::vector<double>& cut, double c_inner) = 0;
    // Writes the bright terms of `rows` into nb (3 per texel; the rows'
    // values are overwritten), relative to the first pass's cmax.
    virtual void bright(const BrightScatter& scatter, const LobeSums& sums, const std::vector<int>& rows,
                        UninitVector<double>& nb) = 0;
};

class Pyramid;
struct ShCoefficients;

// The methods' heavy sums on another device (the GPU engine): `exact` and
// `mipmap` for several maps of one output size per pass, and the cone's sums.
class MethodExecutor {
public:
    virtual ~MethodExecutor() = default;
    // Maps per pass (render targets).
    virtual int max_batch() const = 0;
    virtual std::vector<HdrImage> exact(const HdrImage& input, const std::vector<double>& shininess, Size out) = 0;
    // (irradiance, shininess) per map.
    virtual std::vector<HdrImage> mipmap(const Pyramid& pyramid, const std::vector<std::pair<bool, double>>& maps,
                                         Size out) = 0;
    virtual std::unique_ptr<ConeSumsBackend> cone_sums(const PreparedLevel& level, Size out, double shininess,
                                                       const ConeSettings& settings) = 0;
    // sh_evaluate of the first `order` bands of c: 3 values per texel of out, row 0 first.
    virtual std::vector<double> sh_evaluate(const ShCoefficients& c, int order, const std::vector<double>& kernel,
                                            Size out) = 0;
};

// Where cone_convolve delivers texels instead of a map of its own: (row, column, 3 values).
using TexelSink = std::function<void(int row, int col, const float* rgb)>;
HdrImage cone_convolve(const PreparedLevel& level, const std::vector<BrightTexel>& bright,
                       double shininess, Size out, const ConeSettings& settings, int threads,
                       const RowProgress& progress, ConeStats* stats, const std::vector<int>& only_rows = {},
                       ConeSumsBackend* backend = nullptr,
                       const std::vector<LobeSummer::ColumnRuns>* only_columns = nullptr,
                       const TexelSink* into = nullptr);
// Grids of more output texels than this are summed by cone_convolve (all rows asked, no backend,
// no sink) in bands of rows of about this many texels.
inline constexpr long long kConeBandTexels = 4LL << 20;
// The cone's map of every row, summed band_rows rows at a time (each band a cone_convolve of its
// rows into the one map): memory for the sums of one band. A band is band_rows / 2 northern rows
// (at least one) and their mirrors about the equator, which the Fourier first pass sums in pairs.
// Each band's bounds take its own smallest output, so the result may differ from one call's
// within the tolerance.
HdrImage cone_convolve_in_bands(const PreparedLevel& level, const std::vector<BrightTexel>& bright, double shininess,
                                Size out, const ConeSettings& settings, int threads, const RowProgress& progress,
                                ConeStats* stats, int band_rows);

struct ShCoefficients;
class ShLegendre;

// `sh`: the first `order` bands of `coefficients` (projected from a map of size
// `input`) convolved with the Phong kernel of shininess n, divided by the
// all-ones response (sh_lobe_normaliser); negative values clamped to 0 and
// counted in *clamped.
HdrImage sh_convolve(const ShCoefficients& coefficients, Size input, double shininess, int order, Size out,
                     int threads, long long* clamped, MethodExecutor* executor = nullptr);

// SH with the bright split (used by `auto`): `remainder` holds at least `order`
// bands of the map without its bright texels (mean radiance remainder_mean),
// remainder_ones the all-ones projection of its grid (sh_ones_projection).
// failed_rows lists the output rows holding a channel value whose truncation
// bound tail(order) * remainder_mean exceeds texel_tolerance times the value;
// the caller computes those rows with a method that bounds them (the cone).
struct ShSplitResult {
    HdrImage image;
    std::vector<int> failed_rows;
    long long failed_values = 0;
    long long clamped = 0;
    int bright_fold_order = 0;  // > 0: the bright texels were projected into SH at this order
};
// How the bright texels' terms are added: Auto projects them into SH with the remainder (at an
// order whose truncation bound is no looser than the remainder's alone) where that is predicted
// cheaper than scattering their lobes over the grid (wide lobes, small grids), Scattered always
// scatters them.
enum class BrightTerms { Auto, Scattered };
ShSplitResult sh_split_convolve(const ShCoefficients& remainder, const std::vector<double>& remainder_ones,
                                const ShLegendre& legendre, double remainder_mean,
                                const std::vector<BrightTexel>& bright, double shininess, int order,
                                Size out, double texel_tolerance, double bright_tolerance, int threads,
                                MethodExecutor* executor = nullptr, BrightTerms terms = BrightTerms::Auto);

// The zonal coefficients c_l0, l < order, of the all-ones map projected from a
// map of size `input` (texel solid angle quadrature; the m > 0 sums vanish).
// One per input size serves every map: the normaliser below reads its first
// `order` entries. legendre: any table of at least `order` bands (the
// recurrence coefficients do not depend on its order, so one serves all maps).
std::vector<double> sh_ones_projection(Size input, int order, const ShLegendre& legendre);
// Per output row: the SH result for the all-ones map (ones from
// sh_ones_projection, at least `order` long) with this kernel and order. An SH
// result divided by it has the conventions' discrete normalisation.
std::vector<double> sh_lobe_normaliser(const std::vector<double>& ones, int order, const std::vector<double>& kernel,
                                       Size out, const ShLegendre& legendre);

// sum_{l >= order} |k_l| (2l + 1) for the Phong kernel k_l of shininess n.
double sh_truncation_tail(double shininess, int order);
// The same for every order in [0, max_order], from one kernel (index = order).
std::vector<double> sh_truncation_tails(double shininess, int max_order);

}  // namespace glint::convolution
