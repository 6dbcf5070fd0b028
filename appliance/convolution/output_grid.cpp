// Lookup-error estimates, 4-point resampling and the footprint filter of the mirror map.
#include "appliance/convolution/output_grid.hpp"

#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <string>
#include <vector>

#include "appliance/core/equirect.hpp"
#include "appliance/core/errors.hpp"
#include "appliance/core/parallel.hpp"

namespace glint::convolution {
namespace {

// dst[i] = max(0, sum_k wt[k] rows[k][i]) in float; returns how many were below 0. Sixteen
// values at a time in vector lanes: written as a plain loop GCC kept it scalar (the comparison
// is control flow to it without -ffast-math), and it was 80 % of resample_cubic's time. The
// sums are in float, not double (2026-12-06: the conversions to and from double were a third of
// the resampling's time): the four weights sum to 1 and resampling is used only where the
// map's fourth differences are small, so the rounding is a few 1e-7 of the taps. The same
// operations in the same order as the scalar tail.
long long blend_rows(const std::array<const float*, 4>& rows, const std::array<float, 4>& wt, std::size_t count,
                     float* dst) {
    using Floats = float __attribute__((vector_size(16 * sizeof(float))));
    using Counts = int __attribute__((vector_size(16 * sizeof(int))));
    const auto load = [](const float* p) {
        Floats f;
        std::memcpy(&f, p, sizeof f);
        return f;
    };
    Counts negative = {};
    std::size_t i = 0;
    for (; i + 16 <= count; i += 16) {
        const Floats v = wt[0] * load(rows[0] + i) + wt[1] * load(rows[1] + i) + wt[2] * load(rows[2] + i) +
                         wt[3] * load(rows[3] + i);
        const Counts below = v < 0.0f;  // -1 where below
        negative -= below;
        const Floats kept = below ? Floats{} : v;
        std::memcpy(dst + i, &kept, sizeof kept);
    }
    long long result = 0;
    for (int lane = 0; lane < 16; ++lane) result += negative[lane];
    for (; i < count; ++i) {
        const float v = wt[0] * rows[0][i] + wt[1] * rows[1][i] + wt[2] * rows[2][i] + wt[3] * rows[3][i];
        if (v < 0) ++result;
        dst[i] = v < 0 ? 0.0f : v;
    }
    return result;
}

// Row j + d of an equirect map continued across the poles: past the top (or bottom) row the
// sphere goes on in the row mirrored about the pole, half a turn round.
struct RowTap {
    int row;
    int shift;  // columns to add (mod width)
};
RowTap row_across_pole(int k, int height, int width) {
    if (k < 0) return {std::min(-1 - k, height - 1), width / 2};
    if (k >= height) return {std::max(2 * height - 1 - k, 0), width / 2};
    return {k, 0};
}

int wrap(int i, int width) {
    const int m = i % width;
    return m < 0 ? m + width : m;
}

// A row of `width` texels turned by `shift` columns into `dst` (not `src`).
void copy_turned(const float* src, int width, int shift, float* dst) {
    for (int i = 0; i < width; ++i)
        for (int c = 0; c < 3; ++c) dst[3 * i + c] = src[3 * wrap(i + shift, width) + c];
}

// Row k of `map` continued across the poles (row_across_pole): a pointer into the map, or, for
// a row past a pole, into `scratch`, which receives the mirrored row turned half a turn.
const float* continued_row(const HdrImage& map, int k, std::vector<float>& scratch) {
    const int w = map.width();
    const RowTap t = row_across_pole(k, map.height(), w);
    if (t.shift == 0) return map.row(t.row);
    scratch.resize(std::size_t(3 * w));
    copy_turned(map.row(t.row), w, t.shift, scratch.data());
    return scratch.data();
}

// 4-point Lagrange weights for taps at -1, 0, 1, 2 evaluated at t in [0, 1).
std::array<double, 4> lagrange4(double t) {
    return {-t * (t - 1.0) * (t - 2.0) / 6.0, (t + 1.0) * (t - 1.0) * (t - 2.0) / 2.0,
            -(t + 1.0) * t * (t - 2.0) / 2.0, (t + 1.0) * t * (t - 1.0) / 6.0};
}

// Where an output texel centre falls on the input's grid of centres (in texels).
struct Tap {
    int first;  // index of the tap at -1
    std::array<double, 4> weight;
};
Tap cubic_tap(int out_index, int out_count, int in_count) {
    const double x = (out_index + 0.5) * double(in_count) / double(out_count) - 0.5;
    const double base = std::floor(x);
    return {int(base) - 1, lagrange4(x - base)};
}

// The second and fourth differences of channel c of texel i (rows: j-2 .. j+2, continued
// across the poles; cols: 3 * the columns i-2 .. i+2, wrapped) that the estimates read.
struct Differences {
    double a, b;  // second differences in phi and theta
    double d4;    // |fourth difference in phi| + |fourth difference in theta|
};
Differences differences(const std::array<const float*, 5>& rows, const std::array<int, 5>& cols, int i, int c) {
    const float* centre = rows[2];
    const int k = 3 * i + c;
    const double v = centre[k];
    const double th1 = rows[1][k], th3 = rows[3][k];
    const double ph1 = centre[cols[1] + c], ph3 = centre[cols[3] + c];
    return {ph1 - 2 * v + ph3, th1 - 2 * v + th3,
            std::abs(rows[0][k] - 4 * th1 + 6 * v - 4 * th3 + rows[4][k]) +
                std::abs(centre[cols[0] + c] - 4 * ph1 + 6 * v - 4 * ph3 + centre[cols[4] + c])};
}

// 3 * the columns i-2 .. i+2 of every texel i of a row of `width`, wrapped once.
std::vector<std::array<int, 5>> neighbour_columns(int width) {
    std::vector<std::array<int, 5>> cols(static_cast<std::size_t>(width));
    for (int i = 0; i < width; ++i)
        for (int d = 0; d < 5; ++d) cols[std::size_t(i)][std::size_t(d)] = 3 * wrap(i + d - 2, width);
    return cols;
}

// The differences of every value k = 3 i + c of a row (rows: j-2 .. j+2, continued across the
// poles), planar: a[k], b[k], d4[k] as in `differences`. The texels at least two columns from
// the seam read their neighbours at fixed offsets, a loop GCC vectorises; the four next to the
// seam gather wrapped columns.
struct RowDifferences {
    std::vector<double> a, b, d4;
    void compute(const std::array<const float*, 5>& rows, const std::vector<std::array<int, 5>>& cols, int width) {
        const std::size_t n = 3 * std::size_t(width);
        a.resize(n);
        b.resize(n);
        d4.resize(n);
        const float* __restrict r0 = rows[0];
        const float* __restrict r1 = rows[1];
        const float* __restrict c = rows[2];
        const float* __restrict r3 = rows[3];
        const float* __restrict r4 = rows[4];
        double* __restrict pa = a.data();
        double* __restrict pb = b.data();
        double* __restrict pd = d4.data();
        const int inner_first = 2, inner_last = std::max(2, width - 2);  // texels [first, last)
        for (std::size_t k = 3 * std::size_t(inner_first); k < 3 * std::size_t(inner_last); ++k) {
            const double v = c[k];
            const double th1 = r1[k], th3 = r3[k];
            const double ph1 = c[k - 3], ph3 = c[k + 3];
            pa[k] = ph1 - 2 * v + ph3;
            pb[k] = th1 - 2 * v + th3;
            pd[k] = std::abs(r0[k] - 4 * th1 + 6 * v - 4 * th3 + r4[k]) +
                    std::abs(c[k - 6] - 4 * ph1 + 6 * v - 4 * ph3 + c[k + 6]);
        }
        for (int i = 0; i < width; ++i) {
            if (i >= inner_first && i < inner_last) continue;
            for (int ch = 0; ch < 3; ++ch) {
                const Differences d = differences(rows, cols[std::size_t(i)], i, ch);
                const std::size_t k = 3 * std::size_t(i) + std::size_t(ch);
                pa[k] = d.a;
                pb[k] = d.b;
                pd[k] = d.d4;
            }
        }
    }
};

// Calls visit(j, rows) for every row j of `map` with rows j-2 .. j+2 continued across the poles.
template <typename Visit>
void for_each_row_window(const HdrImage& map, int threads, const Visit& visit) {
    parallel_for(map.height(), threads, [&](int j) {
        std::array<const float*, 5> rows;
        thread_local std::array<std::vector<float>, 5> turned;
        for (int d = 0; d < 5; ++d) rows[std::size_t(d)] = continued_row(map, j + d - 2, turned[std::size_t(d)]);
        visit(j, rows);
    });
}

constexpr double kCubicCoefficient = 3.0 / 128.0;  // largest 4-point error per unit of d4

// Eight doubles in the lanes of one vector: the row sums below keep eight partial sums (and
// maxima) and add them at the row's end. A plain loop stays scalar (a sum's order, and a max's
// comparison, are fixed without -ffast-math); the order changes only the last bits.
using Lanes = double __attribute__((vector_size(8 * sizeof(double))));
constexpr std::size_t kLanes = 8;
Lanes load_lanes(const double* p) {
    Lanes v;
    std::memcpy(&v, p, sizeof v);
    return v;
}
Lanes load_lanes(const float* p) {
    using Floats = float __attribute__((vector_size(8 * sizeof(float))));
    Floats f;
    std::memcpy(&f, p, sizeof f);
    return __builtin_convertvector(f, Lanes);
}
Lanes lane_abs(Lanes v) { return v < 0.0 ? -v : v; }
Lanes lane_max(Lanes a, Lanes b) { return a < b ? b : a; }
double lane_sum(Lanes v) {
    double s = 0;
    for (std::size_t l = 0; l < kLanes; ++l) s += v[l];
    return s;
}
double lane_largest(Lanes v) {
    double m = v[0];
    for (std::size_t l = 1; l < kLanes; ++l) m = std::max(m, v[l]);
    return m;
}
// The share of a first (or last) row's solid angle between the pole and its centres' circle,
// (1 - cos(pi / 2h)) / (1 - cos(pi / h)): 1/4 for a tall map, 1/2 for a map one texel tall.
double pole_cap_share(int height) {
    const double half = kPi / (2.0 * height);
    return (1.0 - std::cos(half)) / (1.0 - std::cos(2.0 * half));
}

// The poles' clamp at value c of texel i of a first or last row of `width` texels: half the
// step to the value half a turn round (the mean of the two columns there for an odd width),
// the error of a lookup at the pole, which holds the row.
double clamp_at_pole(const float* row, int width, int i, int c) {
    const int half = width / 2;
    const double across = row[3 * wrap(i + half, width) + c];
    const double opposite = width % 2 == 0 ? across : 0.5 * (across + double(row[3 * wrap(i + half + 1, width) + c]));
    return 0.5 * std::abs(double(row[3 * i + c]) - opposite);
}

// error / max(|value|, floor_value), the worst-texel metric's ratio; 0 where that floor is 0 (a
// map that is 0 everywhere).
double relative_error(double error, double value, double floor_value) {
    const double floor = std::max(std::abs(value), floor_value);
    return floor > 0 ? error / floor : 0.0;
}

// The largest error of a bilinear lookup over a texel's cell, for a quadratic with the second
// differences of its four neighbours (estimate_lookup_error's worst, one value at a time).
double bilinear_worst_at(double value, double left, double right, double above, double below) {
    return (std::abs(left - 2.0 * value + right) + std::abs(above - 2.0 * value + below)) / 8.0;
}

// x / floor where floor > 0, else 0 (a texel of a map that is 0 everywhere).
Lanes ratio(Lanes x, Lanes floor) { return floor > 0.0 ? x / (floor > 0.0 ? floor : 1.0) : Lanes{}; }

}  // namespace

double solid_angle_mean(const HdrImage& map) {
    const std::vector<double> solid = row_solid_angles(map.width(), map.height());
    const std::size_t n = 3 * std::size_t(map.width());
    double sum = 0;
    for (int j = 0; j < map.height(); ++j) {
        const float* p = map.row(j);
        Lanes lanes = {};
        std::size_t i = 0;
        for (; i + kLanes <= n; i += kLanes) lanes += lane_abs(load_lanes(p + i));
        double row = lane_sum(lanes);
        for (; i < n; ++i) row += std::abs(p[i]);
        sum += row * solid[std::size_t(j)];
    }
    return sum / (3.0 * 4.0 * kPi);
}

LookupError horizon_step_error(const HdrImage& input, const HdrImage& map, double n) {
    LookupError e;
    if (!(n < 1.0) || map.empty() || input.empty()) return e;
    const int w = map.width(), h = map.height();
    const double spacing = kPi / h;
    std::vector<double> cells(3 * std::size_t(w) * std::size_t(h), 0.0);
    const std::vector<double> omega = row_solid_angles(input.width(), input.height());
    for (int j = 0; j < input.height(); ++j) {
        const int cj = std::min(h - 1, int((long long)j * h / input.height()));
        const float* p = input.row(j);
        double* row = cells.data() + 3 * std::size_t(cj) * std::size_t(w);
        for (int i = 0; i < input.width(); ++i) {
            const int ci = std::min(w - 1, int((long long)i * w / input.width()));
            for (int c = 0; c < 3; ++c) row[3 * std::size_t(ci) + std::size_t(c)] += double(p[3 * i + c]) * omega[std::size_t(j)];
        }
    }
    const double m = std::max(n, 0.0);
    const double step = std::pow(spacing, m) * (1.0 + m) / (2.0 * kPi);
    // Mean square of linear interpolation against the rise (x/h)^n over the cell it begins in,
    // 1/(2n + 1) - 2/(n + 2) + 1/3, halved for where in the cell it begins: 1/6 for the step
    // (n = 0), 1/18 at n = 0.25, 1/60 at 0.5, 1/2600 at 0.9. Its largest value n^(n/(1-n)) -
    // n^(1/(1-n)): 1 for the step, 0.47, 0.25, 0.04.
    const double mean_square = 0.5 * (1.0 / (2.0 * m + 1.0) - 2.0 / (m + 2.0) + 1.0 / 3.0);
    const double peak = m > 0 ? std::pow(m, m / (1.0 - m)) - std::pow(m, 1.0 / (1.0 - m)) : 1.0;
    // A cell's step is what it holds beyond its eight neighbours' mean: the steps of a source
    // wider than a cell, or of a smooth sky, lie a cell apart and make a ramp that lookups
    // follow (counted whole, courtyard's phong_0 was predicted 1.8 % against 0.34 % measured).
    double error_squares = 0, largest = 0;
    for (int j = 0; j < h; ++j)
        for (int i = 0; i < w; ++i)
            for (int c = 0; c < 3; ++c) {
                double around = 0;
                for (int dj = -1; dj <= 1; ++dj)
                    for (int di = -1; di <= 1; ++di) {
                        if (di == 0 && dj == 0) continue;
                        const int jj = std::clamp(j + dj, 0, h - 1), ii = (i + di + w) % w;
                        around += cells[3 * (std::size_t(jj) * std::size_t(w) + std::size_t(ii)) + std::size_t(c)];
                    }
                const double own = cells[3 * (std::size_t(j) * std::size_t(w) + std::size_t(i)) + std::size_t(c)];
                const double jump = std::abs(own - around / 8.0) * step;
                error_squares += 2.0 * kPi * spacing * jump * jump * mean_square;
                largest = std::max(largest, jump * peak);
            }
    const std::vector<double> solid = row_solid_angles(w, h);
    double squares = 0;
    for (int j = 0; j < h; ++j) {
        const float* p = map.row(j);
        double row = 0;
        for (int k = 0; k < 3 * w; ++k) row += double(p[k]) * double(p[k]);
        squares += row * solid[std::size_t(j)];
    }
    const double mean = solid_angle_mean(map);
    e.bilinear_rms = squares > 0 ? std::sqrt(error_squares / squares) : 0.0;
    e.bilinear_worst = mean > 0 ? 0.5 * largest / mean : 0.0;
    return e;
}

LookupError::Bilinear LookupError::finer(int factor) const {
    const double f = factor, f2 = f * f;
    return {bilinear_rms / f2, std::max(between_worst / f2, pole_worst / f)};
}

LookupError estimate_lookup_error(const HdrImage& map, int threads, TexelLookupErrors* per_texel) {
    const int w = map.width(), h = map.height();
    const std::vector<double> solid = row_solid_angles(w, h);
    const double mean = solid_angle_mean(map);
    struct RowSums {
        double value2 = 0, bilinear2 = 0, cubic2 = 0, bilinear_worst = 0, cubic_worst = 0;
        double pole_worst = 0, between_worst = 0;
    };
    std::vector<RowSums> rows_sums(static_cast<std::size_t>(h));
    const std::vector<std::array<int, 5>> cols = neighbour_columns(w);
    const std::size_t n = 3 * std::size_t(w);
    if (per_texel) {
        for (TexelErrors* e : {&per_texel->bilinear, &per_texel->cubic}) {
            e->relative.resize(map.texel_count());
            e->square.resize(map.texel_count());
        }
    }
    for_each_row_window(map, threads, [&](int j, const std::array<const float*, 5>& rows) {
        thread_local RowDifferences d;
        d.compute(rows, cols, w);
        // Per value: its mean square bilinear error over the texel's cell, for a quadratic with
        // these second differences, e = a t(1-t)/2 + b s(1-s)/2 for t, s uniform in [0, 1];
        // the largest bilinear and 4-point errors, relative to max(|value|, mean).
        Lanes value2 = {}, bilinear2 = {}, cubic2 = {}, bilinear_worst = {}, cubic_worst = {};
        // With per_texel: each value's relative errors and squares, kept for the texels below.
        thread_local std::vector<double> rel_b, rel_c, sq_b, sq_c;
        if (per_texel) {
            for (std::vector<double>* v : {&rel_b, &rel_c, &sq_b, &sq_c}) v->resize(n + kLanes);
        }
        const auto add = [&](std::size_t at, Lanes v, Lanes a, Lanes b, Lanes d4) {
            const Lanes bilinear = (lane_abs(a) + lane_abs(b)) / 8.0, cubic = d4 * kCubicCoefficient;
            const Lanes floor = lane_max(lane_abs(v), Lanes{} + mean);
            const Lanes square_b = (a * a + b * b) / 120.0 + a * b / 72.0, square_c = cubic * cubic;
            const Lanes ratio_b = ratio(bilinear, floor), ratio_c = ratio(cubic, floor);
            value2 += v * v;
            bilinear2 += square_b;
            cubic2 += square_c;
            bilinear_worst = lane_max(bilinear_worst, ratio_b);
            cubic_worst = lane_max(cubic_worst, ratio_c);
            if (per_texel) {
                std::memcpy(rel_b.data() + at, &ratio_b, sizeof ratio_b);
                std::memcpy(rel_c.data() + at, &ratio_c, sizeof ratio_c);
                std::memcpy(sq_b.data() + at, &square_b, sizeof square_b);
                std::memcpy(sq_c.data() + at, &square_c, sizeof square_c);
            }
        };
        std::size_t k = 0;
        for (; k + kLanes <= n; k += kLanes)
            add(k, load_lanes(rows[2] + k), load_lanes(d.a.data() + k), load_lanes(d.b.data() + k),
                load_lanes(d.d4.data() + k));
        for (; k < n; ++k) {  // the rest one lane at a time, the other lanes 0
            const auto one = [](double x) { return Lanes{x}; };
            add(k, one(rows[2][k]), one(d.a[k]), one(d.b[k]), one(d.d4[k]));
        }
        RowSums& sums = rows_sums[std::size_t(j)];
        sums = {lane_sum(value2), lane_sum(bilinear2), lane_sum(cubic2), lane_largest(bilinear_worst),
                lane_largest(cubic_worst)};
        sums.between_worst = sums.bilinear_worst;
        // The poles' clamp (the first and last rows; both for a map one texel tall), scalar:
        // two rows of the map.
        for (const int pole : {0, h - 1}) {
            if (j != pole) continue;
            const double cap = pole_cap_share(h);
            for (int i = 0; i < w; ++i)
                for (int c = 0; c < 3; ++c) {
                    const std::size_t at = 3 * std::size_t(i) + std::size_t(c);
                    const double clamp = clamp_at_pole(rows[2], w, i, c);
                    const double square = clamp * clamp / 6.0 * cap;
                    const double relative = relative_error(clamp, rows[2][at], mean);
                    sums.bilinear2 += square;
                    sums.bilinear_worst = std::max(sums.bilinear_worst, relative);
                    sums.pole_worst = std::max(sums.pole_worst, relative);
                    if (per_texel) {
                        sq_b[at] += square;
                        rel_b[at] = std::max(rel_b[at], relative);
                    }
                }
        }
        if (!per_texel) return;
        // Per texel, the same estimates over its three channels: the largest relative error and
        // the weighted sum of squares, of both kinds.
        const double sa = solid[std::size_t(j)];
        for (int i = 0; i < w; ++i) {
            const std::size_t q = 3 * std::size_t(i);
            const double rb = std::max({rel_b[q], rel_b[q + 1], rel_b[q + 2]});
            const double rc = std::max({rel_c[q], rel_c[q + 1], rel_c[q + 2]});
            const std::size_t t = std::size_t(j) * std::size_t(w) + std::size_t(i);
            per_texel->bilinear.relative[t] = float(rb);
            per_texel->bilinear.square[t] = (sq_b[q] + sq_b[q + 1] + sq_b[q + 2]) * sa;
            per_texel->cubic.relative[t] = float(rc);
            per_texel->cubic.square[t] = (sq_c[q] + sq_c[q + 1] + sq_c[q + 2]) * sa;
        }
    });
    double value2 = 0, bilinear2 = 0, cubic2 = 0;
    LookupError e;
    for (int j = 0; j < h; ++j) {
        const RowSums& s = rows_sums[std::size_t(j)];
        const double a = solid[std::size_t(j)];
        value2 += a * s.value2;
        bilinear2 += a * s.bilinear2;
        cubic2 += a * s.cubic2;
        e.bilinear_worst = std::max(e.bilinear_worst, s.bilinear_worst);
        e.cubic_worst = std::max(e.cubic_worst, s.cubic_worst);
        e.pole_worst = std::max(e.pole_worst, s.pole_worst);
        e.between_worst = std::max(e.between_worst, s.between_worst);
    }
    if (value2 > 0) {
        e.bilinear_rms = std::sqrt(bilinear2 / value2);
        e.cubic_rms = std::sqrt(cubic2 / value2);
    }
    if (per_texel) per_texel->bilinear.value2 = per_texel->cubic.value2 = value2;
    return e;
}

namespace {

// The texels whose relative error exceeds worst_budget, then those with the largest shares of
// the squared error until the rest is within rms_budget (relative RMS); what the unmarked
// texels leave.
struct Marking {
    std::vector<char> marked;
    long long count = 0;
    double remaining_rms = 0, remaining_worst = 0;
};
Marking mark_largest_errors(const TexelErrors& e, double rms_budget, double worst_budget) {
    const std::size_t texels = e.relative.size();
    Marking result;
    result.marked.assign(texels, 0);
    std::vector<char>& marked = result.marked;
    double rest = 0;  // weighted squared error of the unmarked texels
    for (std::size_t t = 0; t < texels; ++t) {
        if (e.relative[t] > worst_budget) {
            marked[t] = 1;
            ++result.count;
        } else {
            rest += e.square[t];
        }
    }
    // Then the largest contributions to the RMS until the rest is within its budget: the
    // contributions binned by their power of two, whole bins marked from the top, and the
    // bin where the budget is crossed sorted (a sort of every texel took a tenth of a map's
    // delivery at 4096x2048).
    const double allowed = rms_budget * rms_budget * e.value2;
    if (rest > allowed) {
        // A value's bin is its binary exponent field (0 for 0 and subnormals): what ilogb gives,
        // biased, without a call per texel.
        constexpr int kBins = 2048;
        const auto bin = [](double sq) {
            std::uint64_t bits;
            std::memcpy(&bits, &sq, sizeof bits);
            return sq > 0 ? int((bits >> 52) & 0x7ff) : 0;
        };
        std::vector<double> bin_sum(kBins, 0.0);
        for (std::size_t t = 0; t < texels; ++t)
            if (!marked[t]) bin_sum[std::size_t(bin(e.square[t]))] += e.square[t];
        // The lowest bins whose sum stays within the budget are kept; `cross` is the first
        // bin that would exceed it.
        double kept = 0;
        int cross = 0;
        while (cross < kBins && kept + bin_sum[std::size_t(cross)] <= allowed) kept += bin_sum[std::size_t(cross++)];
        std::vector<std::size_t> crossing;
        for (std::size_t t = 0; t < texels; ++t) {
            if (marked[t]) continue;
            const int b = bin(e.square[t]);
            if (b > cross) {
                marked[t] = 1;
                ++result.count;
                rest -= e.square[t];
            } else if (b == cross) {
                crossing.push_back(t);
            }
        }
        std::sort(crossing.begin(), crossing.end(),
                  [&](std::size_t a, std::size_t b) { return e.square[a] > e.square[b]; });
        for (std::size_t t : crossing) {
            if (rest <= allowed) break;
            marked[t] = 1;
            ++result.count;
            rest -= e.square[t];
        }
    }
    for (std::size_t t = 0; t < texels; ++t)
        if (!marked[t]) result.remaining_worst = std::max(result.remaining_worst, double(e.relative[t]));
    result.remaining_rms = e.value2 > 0 ? std::sqrt(std::max(0.0, rest) / e.value2) : 0.0;
    return result;
}

}  // namespace

ResamplePatches plan_resample_patches(const HdrImage& map, double rms_budget, double worst_budget, int threads,
                                      const TexelLookupErrors* known) {
    const int w = map.width(), h = map.height();
    TexelLookupErrors measured;
    if (!known) {
        estimate_lookup_error(map, threads, &measured);
        known = &measured;
    }
    const Marking m = mark_largest_errors(known->cubic, rms_budget, worst_budget);
    ResamplePatches result;
    result.count = m.count;
    result.remaining_rms = m.remaining_rms;
    result.remaining_worst = m.remaining_worst;
    // A texel's error estimate covers the cells around it: its neighbours are marked too
    // (across the seam and the poles).
    result.texels.assign(m.marked.size(), 0);
    for (int j = 0; j < h; ++j)
        for (int i = 0; i < w; ++i) {
            if (!m.marked[std::size_t(j) * std::size_t(w) + std::size_t(i)]) continue;
            for (int dj = -1; dj <= 1; ++dj) {
                const RowTap r = row_across_pole(j + dj, h, w);
                for (int di = -1; di <= 1; ++di)
                    result.texels[std::size_t(r.row) * std::size_t(w) + std::size_t(wrap(i + di + r.shift, w))] = 1;
            }
        }
    return result;
}

FineTilePlan plan_fine_tiles(const HdrImage& base, int factor, int tile, double rms_budget, double worst_budget,
                             int threads, const TexelLookupErrors* known) {
    const int w = base.width(), h = base.height();
    FineTilePlan plan;
    plan.factor = factor;
    plan.tile = tile;
    if (!FineTiles::fits(w, h, tile) || factor < 2) return plan;
    plan.tiles_x = w / tile;
    plan.tiles_y = h / tile;
    plan.kept.assign(std::size_t(plan.tiles_x) * std::size_t(plan.tiles_y), 0);
    TexelLookupErrors measured;
    if (!known) {
        estimate_lookup_error(base, threads, &measured);
        known = &measured;
    }
    const Marking m = mark_largest_errors(known->bilinear, rms_budget, worst_budget);
    plan.marked = m.count;
    plan.remaining_rms = m.remaining_rms;
    plan.remaining_worst = m.remaining_worst;
    // Base texel i's centre is fine coordinate (i + 0.5) factor - 0.5 (in fine texel centres);
    // the cells between its neighbours' centres span fine cells [lo, hi], one more each side
    // for rounding. Columns wrap (tiles modulo tiles_x); rows clamp, as lookups do.
    const int t = tile * factor, fh = h * factor;
    const auto floor_div = [](int a, int b) { return a >= 0 ? a / b : -((-a + b - 1) / b); };
    for (int j = 0; j < h; ++j)
        for (int i = 0; i < w; ++i) {
            if (!m.marked[std::size_t(j) * std::size_t(w) + std::size_t(i)]) continue;
            const int x_lo = int(std::floor((i - 0.5) * factor - 0.5)) - 1;
            const int x_hi = int(std::floor((i + 1.5) * factor - 0.5)) + 1;
            const int y_lo = std::clamp(int(std::floor((j - 0.5) * factor - 0.5)) - 1, 0, fh - 1);
            const int y_hi = std::clamp(int(std::floor((j + 1.5) * factor - 0.5)) + 1, 0, fh - 1);
            for (int ty = y_lo / t; ty <= y_hi / t; ++ty)
                for (int tx = floor_div(x_lo, t); tx <= floor_div(x_hi, t); ++tx) {
                    char& k = plan.kept[std::size_t(ty) * std::size_t(plan.tiles_x) + std::size_t(wrap(tx, plan.tiles_x))];
                    if (!k) ++plan.tiles;
                    k = 1;
                }
        }
    return plan;
}

double pole_clamp_worst(const HdrImage& map, double floor_value) {
    double worst = 0;
    for (const int j : {0, map.height() - 1})
        for (int i = 0; i < map.width(); ++i)
            for (int c = 0; c < 3; ++c)
                worst = std::max(worst, relative_error(clamp_at_pole(map.row(j), map.width(), i, c),
                                                       map.row(j)[3 * i + c], floor_value));
    return worst;
}

// The spots' exact sums leave out texels under e^-20 of the largest (2e-9: far below the
// percent the worst lookup is compared with), 1.8x fewer than the lobe lookup's e^-36.
constexpr double kSpotSpan = 20.0;

double spot_lookup_worst(const HdrImage& input, double n, Size grid, int spots, int threads) {
    const int w = input.width(), h = input.height();
    if (input.empty() || grid.width < 3 || grid.height < 3 || spots <= 0) return 0;
    TexelLookupErrors own;
    estimate_lookup_error(input, threads, &own);
    const std::vector<float>& rough = own.bilinear.relative;
    std::vector<std::size_t> order(rough.size());
    for (std::size_t t = 0; t < order.size(); ++t) order[t] = t;
    const std::size_t count = std::min(order.size(), std::size_t(spots));
    std::partial_sort(order.begin(), order.begin() + std::ptrdiff_t(count), order.end(),
                      [&](std::size_t a, std::size_t b) { return rough[a] > rough[b]; });
    const double floor_value = solid_angle_mean(input);
    std::vector<double> worst(count, 0.0);
    parallel_for(int(count), threads, [&](int s) {
        const int i = int(order[std::size_t(s)] % std::size_t(w)), j = int(order[std::size_t(s)] / std::size_t(w));
        // The spot's texel and one on each side, on the grid, and a grid texel more round them.
        const int r0 = std::max(0, int(std::floor(double(j - 1) * grid.height / h)) - 1);
        const int r1 = std::min(grid.height - 1, int(std::ceil(double(j + 2) * grid.height / h)) + 1);
        const int c0 = int(std::floor(double(i - 1) * grid.width / w)) - 1;
        const int c1 = int(std::ceil(double(i + 2) * grid.width / w)) + 1;
        const int rows = r1 - r0 + 1, cols = std::min(c1 - c0 + 1, grid.width + 2);
        std::vector<double> v(3 * std::size_t(rows) * std::size_t(cols));
        for (int y = 0; y < rows; ++y)
            for (int x = 0; x < cols; ++x) {
                const int col = ((c0 + x) % grid.width + grid.width) % grid.width;
                const Rgb e = sample_lobe(input, texel_direction(col, r0 + y, grid.width, grid.height), n, kSpotSpan);
                double* into = v.data() + 3 * (std::size_t(y) * std::size_t(cols) + std::size_t(x));
                into[0] = e.r;
                into[1] = e.g;
                into[2] = e.b;
            }
        const auto at = [&](int y, int x, int c) {
            return v[3 * (std::size_t(y) * std::size_t(cols) + std::size_t(x)) + std::size_t(c)];
        };
        double largest = 0;
        for (int y = 1; y + 1 < rows; ++y)
            for (int x = 1; x + 1 < cols; ++x)
                for (int c = 0; c < 3; ++c) {
                    const double value = at(y, x, c);
                    const double error =
                        bilinear_worst_at(value, at(y, x - 1, c), at(y, x + 1, c), at(y - 1, x, c), at(y + 1, x, c));
                    largest = std::max(largest, relative_error(error, value, floor_value));
                }
        worst[std::size_t(s)] = largest;
    });
    return worst.empty() ? 0.0 : *std::max_element(worst.begin(), worst.end());
}

TileLookupWorst tile_lookup_worst(const HdrImage& base, const FineTiles& tiles, double floor_value) {
    TileLookupWorst worst;
    if (tiles.empty()) return worst;
    const int side = tiles.side(), t = tiles.tile * tiles.factor;
    const int fw = base.width() * tiles.factor, fh = base.height() * tiles.factor;
    const auto add = [&](double& into, double error, double value) {
        into = std::max(into, relative_error(error, value, floor_value));
    };
    // The poles' clamp in the first and last fine rows: against what a lookup reads half a
    // turn round (a fine texel where a tile holds it, the base's lookup elsewhere).
    for (int ty : {0, tiles.tiles_y - 1})
        for (int tx = 0; tx < tiles.tiles_x; ++tx) {
            const int k = tiles.slot[std::size_t(ty) * std::size_t(tiles.tiles_x) + std::size_t(tx)];
            if (k < 0) continue;
            const int v = ty == 0 ? 0 : side - 1, j = ty == 0 ? 0 : fh - 1;
            const float* row = tiles.blocks.row(k * side + v);
            for (int u = 0; u < side; ++u) {
                const int i = (tx * t + u) % fw;
                const Rgb across = sample_bilinear(base, tiles, texel_direction((i + fw / 2) % fw, j, fw, fh));
                const double opposite[3] = {across.r, across.g, across.b};
                for (int c = 0; c < 3; ++c)
                    add(worst.pole, 0.5 * std::abs(double(row[3 * u + c]) - opposite[c]), row[3 * u + c]);
            }
        }
    // Each block's interior texels. In the last tile row the block's rows T - 1 and T are both
    // the last fine row (a row past it is it again), so rows up to T - 2 only: differenced
    // against itself, the last row would give a first difference, the clamp's slope.
    for (int ty = 0; ty < tiles.tiles_y; ++ty)
        for (int tx = 0; tx < tiles.tiles_x; ++tx) {
            const int k = tiles.slot[std::size_t(ty) * std::size_t(tiles.tiles_x) + std::size_t(tx)];
            if (k < 0) continue;
            const int last = ty == tiles.tiles_y - 1 ? side - 3 : side - 2;
            for (int v = 1; v <= last; ++v) {
                const float* above = tiles.blocks.row(k * side + v - 1);
                const float* row = tiles.blocks.row(k * side + v);
                const float* below = tiles.blocks.row(k * side + v + 1);
                for (int q = 3; q < 3 * (side - 1); ++q) {
                    const double value = row[q];
                    add(worst.between, bilinear_worst_at(value, row[q - 3], row[q + 3], above[q], below[q]), value);
                }
            }
        }
    return worst;
}

FineTiles make_fine_tiles(const HdrImage& map, const FineTilePlan& plan, int threads, long long* clamped,
                          const BrightLobes* lobes) {
    FineTiles f;
    f.factor = plan.factor;
    f.tile = plan.tile;
    f.tiles_x = plan.tiles_x;
    f.tiles_y = plan.tiles_y;
    f.slot.assign(plan.kept.size(), -1);
    std::vector<int> order;  // tile indices of the blocks, in slot order
    for (std::size_t k = 0; k < plan.kept.size(); ++k)
        if (plan.kept[k]) {
            f.slot[k] = int(order.size());
            order.push_back(int(k));
        }
    if (order.empty()) return FineTiles{};
    const int w = map.width(), h = map.height();
    const int fw = w * f.factor, fh = h * f.factor, t = f.tile * f.factor, side = f.side();
    f.blocks = HdrImage(side, side * int(order.size()), HdrImage::Unwritten{});
    // Per block: the fine columns' taps (wrapped) and rows' taps (continued across the poles,
    // a row past one read half a turn round), both passes in float as resample_cubic sums.
    std::atomic<long long> negative{0};
    parallel_for(int(order.size()), threads, [&](int k) {
        const int tx = order[std::size_t(k)] % f.tiles_x, ty = order[std::size_t(k)] / f.tiles_x;
        thread_local std::vector<std::array<int, 4>> col_index;
        thread_local std::vector<std::array<float, 4>> col_weight;
        col_index.resize(std::size_t(side));
        col_weight.resize(std::size_t(side));
        for (int u = 0; u < side; ++u) {
            const int i = (tx * t + u) % fw;
            const Tap c = cubic_tap(i, fw, w);
            for (int q = 0; q < 4; ++q) {
                col_index[std::size_t(u)][std::size_t(q)] = wrap(c.first + q, w);
                col_weight[std::size_t(u)][std::size_t(q)] = float(c.weight[std::size_t(q)]);
            }
        }
        // The base rows the block's fine rows read, each resampled across once.
        const int j_first = ty * t, j_last = std::min(ty * t + t, fh - 1);
        const int r_first = cubic_tap(j_first, fh, h).first, r_last = cubic_tap(j_last, fh, h).first + 3;
        thread_local std::vector<float> across;
        across.resize(std::size_t(r_last - r_first + 1) * 3 * std::size_t(side));
        for (int r = r_first; r <= r_last; ++r) {
            const RowTap rt = row_across_pole(r, h, w);
            const float* src = map.row(rt.row);
            float* dst = across.data() + std::size_t(r - r_first) * 3 * std::size_t(side);
            for (int u = 0; u < side; ++u) {
                const std::array<int, 4>& ci = col_index[std::size_t(u)];
                const std::array<float, 4>& cw = col_weight[std::size_t(u)];
                for (int c = 0; c < 3; ++c) {
                    float v = 0;
                    for (int q = 0; q < 4; ++q)
                        v += cw[std::size_t(q)] * src[3 * wrap(ci[std::size_t(q)] + rt.shift, w) + c];
                    dst[3 * u + c] = v;
                }
            }
        }
        long long below = 0;
        for (int v = 0; v < side; ++v) {
            const int j = std::min(ty * t + v, fh - 1);
            const Tap rt = cubic_tap(j, fh, h);
            float* out = f.blocks.row(k * side + v);
            for (int u = 0; u < side; ++u)
                for (int c = 0; c < 3; ++c) {
                    float s = 0;
                    for (int q = 0; q < 4; ++q)
                        s += float(rt.weight[std::size_t(q)]) *
                             across[std::size_t(rt.first + q - r_first) * 3 * std::size_t(side) + 3 * std::size_t(u) + std::size_t(c)];
                    if (s < 0 && u < t && v < t) ++below;  // each fine texel counted once, in its own tile
                    out[3 * u + c] = s < 0 ? 0.0f : s;
                }
        }
        negative += below;
    });
    if (clamped) *clamped += negative.load();
    if (lobes) {
        // Per fine row: the blocks' columns on it as runs within one window, the lobes added
        // there once, then copied back into each block's row.
        const TexelSelection all = fine_tile_texels(plan, {w, h});
        parallel_for(int(all.rows.size()), threads, [&](int q) {
            const int j = all.rows[std::size_t(q)];
            const LobeSummer::ColumnRuns& runs = all.runs[std::size_t(q)];
            const int first = runs.front().first, count = runs.back().second - first;
            thread_local std::vector<float> row;
            row.assign(3 * std::size_t(count), 0.0f);
            // The resampled values in, from a block that holds each.
            for (const auto& [a, b] : runs)
                for (int i = a; i < b; ++i)
                    std::copy_n(fine_texel(f, {w, h}, i, j), 3, row.data() + 3 * std::size_t(i - first));
            lobes->apply_runs(j, runs, first, count, row.data());
            for (const auto& [a, b] : runs)
                for (int i = a; i < b; ++i) set_fine_texel(f, {w, h}, i, j, row.data() + 3 * std::size_t(i - first));
        });
    }
    return f;
}

TexelSelection fine_tile_texels(const FineTilePlan& plan, Size base) {
    TexelSelection s;
    if (plan.kept.empty()) return s;
    const int t = plan.tile * plan.factor, fw = base.width * plan.factor, fh = base.height * plan.factor;
    std::vector<char> column(static_cast<std::size_t>(fw));
    for (int j = 0; j < fh; ++j) {
        // Tile rows holding fine row j: its own, and the one above when j is its first row.
        std::fill(column.begin(), column.end(), 0);
        bool any = false;
        for (int ty : {j / t, j % t == 0 ? j / t - 1 : -1}) {
            if (ty < 0 || ty >= plan.tiles_y) continue;
            for (int tx = 0; tx < plan.tiles_x; ++tx) {
                if (!plan.kept[std::size_t(ty) * std::size_t(plan.tiles_x) + std::size_t(tx)]) continue;
                any = true;
                for (int u = 0; u <= t; ++u) column[std::size_t((tx * t + u) % fw)] = 1;
            }
        }
        if (!any) continue;
        LobeSummer::ColumnRuns runs;
        for (int i = 0; i < fw; ++i) {
            if (!column[std::size_t(i)]) continue;
            if (!runs.empty() && runs.back().second == i)
                runs.back().second = i + 1;
            else
                runs.emplace_back(i, i + 1);
        }
        for (const auto& [a, b] : runs) s.texels += b - a;
        s.rows.push_back(j);
        s.runs.push_back(std::move(runs));
    }
    return s;
}

TexelSelection intersect(const TexelSelection& a, const TexelSelection& b) {
    TexelSelection s;
    std::size_t q = 0;
    for (std::size_t p = 0; p < a.rows.size(); ++p) {
        while (q < b.rows.size() && b.rows[q] < a.rows[p]) ++q;
        if (q == b.rows.size()) break;
        if (b.rows[q] != a.rows[p]) continue;
        LobeSummer::ColumnRuns runs;
        const LobeSummer::ColumnRuns &ra = a.runs[p], &rb = b.runs[q];
        std::size_t x = 0, y = 0;
        while (x < ra.size() && y < rb.size()) {
            const int lo = std::max(ra[x].first, rb[y].first), hi = std::min(ra[x].second, rb[y].second);
            if (lo < hi) runs.emplace_back(lo, hi);
            if (ra[x].second < rb[y].second)
                ++x;
            else
                ++y;
        }
        if (runs.empty()) continue;
        for (const auto& [lo, hi] : runs) s.texels += hi - lo;
        s.rows.push_back(a.rows[p]);
        s.runs.push_back(std::move(runs));
    }
    return s;
}

const float* fine_texel(const FineTiles& f, Size base, int i, int j) {
    const float* found = nullptr;
    for_each_block_holding(f, base.height, i, j, [&](int slot, int u, int v) {
        if (!found) found = f.blocks.row(slot * f.side() + v) + 3 * u;
    });
    if (!found) throw RuntimeError("internal: no fine tile holds texel " + std::to_string(i) + ", " + std::to_string(j));
    return found;
}

void set_fine_texel(FineTiles& f, Size base, int i, int j, const float* rgb) {
    for_each_block_holding(f, base.height, i, j, [&](int slot, int u, int v) {
        std::copy_n(rgb, 3, f.blocks.row(slot * f.side() + v) + 3 * u);
    });
}

TexelSelection fine_texels_near(const std::vector<char>& marked, Size coarse, Size fine, int threads) {
    // The coarse column (and row) at or left of an output texel centre: its cell lies between
    // that centre and the next.
    const auto base = [](int index, int out_count, int in_count) {
        return int(std::floor((index + 0.5) * double(in_count) / double(out_count) - 0.5));
    };
    std::vector<int> column_base(static_cast<std::size_t>(fine.width));
    for (int i = 0; i < fine.width; ++i) column_base[std::size_t(i)] = wrap(base(i, fine.width, coarse.width), coarse.width);
    // The runs depend only on the coarse row at or above the output row (a few output rows
    // share it when `fine` is finer), so they are found once per coarse row.
    const int first_base = base(0, fine.height, coarse.height);
    const int last_base = base(fine.height - 1, fine.height, coarse.height);
    std::vector<LobeSummer::ColumnRuns> base_runs(static_cast<std::size_t>(last_base - first_base + 1));
    parallel_for(last_base - first_base + 1, threads, [&](int q) {
        // The two coarse rows around these output rows (continued across the poles), OR-ed
        // column by column; a cell is marked if either of its columns is.
        const int b = first_base + q;
        thread_local std::vector<char> either;
        either.assign(static_cast<std::size_t>(coarse.width), 0);
        bool any = false;
        for (const RowTap r : {row_across_pole(b, coarse.height, coarse.width),
                               row_across_pole(b + 1, coarse.height, coarse.width)}) {
            const char* m = marked.data() + std::size_t(r.row) * std::size_t(coarse.width);
            const int shift = wrap(r.shift, coarse.width);
            for (int c = 0; c < coarse.width; ++c) {
                const int from = c + shift;
                const char v = m[from >= coarse.width ? from - coarse.width : from];
                either[std::size_t(c)] |= v;
                any = any || v;
            }
        }
        if (!any) return;
        LobeSummer::ColumnRuns& runs = base_runs[std::size_t(q)];
        for (int i = 0; i < fine.width; ++i) {
            const int c = column_base[std::size_t(i)];
            if (!(either[std::size_t(c)] || either[std::size_t(c + 1 == coarse.width ? 0 : c + 1)])) continue;
            if (!runs.empty() && runs.back().second == i)
                runs.back().second = i + 1;
            else
                runs.emplace_back(i, i + 1);
        }
    });
    TexelSelection selection;
    for (int jf = 0; jf < fine.height; ++jf) {
        const LobeSummer::ColumnRuns& runs =
            base_runs[std::size_t(base(jf, fine.height, coarse.height) - first_base)];
        if (runs.empty()) continue;
        for (const auto& [first, last] : runs) selection.texels += last - first;
        selection.rows.push_back(jf);
        selection.runs.push_back(runs);
    }
    return selection;
}

HdrImage resample_cubic(const HdrImage& map, Size out, int threads, long long* clamped, const BrightLobes* lobes) {
    const int w = map.width(), h = map.height();
    // Per output column: its four input columns (wrapped) and weights.
    std::vector<Tap> columns;
    std::vector<std::array<int, 4>> column_index;
    std::vector<char> reads_last_texel;  // per output column: a tap is the row's last texel
    for (int i = 0; i < out.width; ++i) {
        columns.push_back(cubic_tap(i, out.width, w));
        std::array<int, 4> idx;
        bool last = false;
        for (int k = 0; k < 4; ++k) {
            idx[std::size_t(k)] = 3 * wrap(columns.back().first + k, w);
            last = last || idx[std::size_t(k)] == 3 * (w - 1);
        }
        column_index.push_back(idx);
        reads_last_texel.push_back(last ? 1 : 0);
    }
    // Pass 1 (an input row to the output's columns) feeds pass 2 (down the columns, across the
    // poles) band by band: each band of output rows resamples across only the input rows it
    // reads, into a buffer of its thread, so no whole map of pass-1 rows is ever made (25 MB of
    // fresh pages for a 4096x2048 output from 512 rows). The band's rows of input are resampled
    // once per band, not once per output row; a band of 16 rows four times finer re-does 3 of
    // every 7. The arithmetic is the two passes' own, so the result is the same to the bit.
    // A texel's three channels in the lanes of one vector of four: its loads read one float past
    // the texel and its store writes one past (into the next texel, written after it, or the
    // buffer's padding), so a tap of the row's last texel, whose fourth float may lie past the
    // image, takes the scalar sums. The same float arithmetic in each lane as in those (float,
    // as blend_rows).
    using Floats4 = float __attribute__((vector_size(4 * sizeof(float))));
    std::vector<std::array<float, 4>> column_weight(columns.size());
    for (std::size_t i = 0; i < columns.size(); ++i)
        for (std::size_t k = 0; k < 4; ++k) column_weight[i][k] = float(columns[i].weight[k]);
    const auto across_row = [&](int j, float* dst) {
        const float* src = map.row(j);
        const auto texel = [&](int at) {
            Floats4 f;
            std::memcpy(&f, src + at, sizeof f);
            return f;
        };
        for (int i = 0; i < out.width; ++i) {
            const std::array<float, 4>& wt = column_weight[std::size_t(i)];
            const std::array<int, 4>& idx = column_index[std::size_t(i)];
            if (!reads_last_texel[std::size_t(i)]) {
                const Floats4 v = wt[0] * texel(idx[0]) + wt[1] * texel(idx[1]) + wt[2] * texel(idx[2]) +
                                  wt[3] * texel(idx[3]);
                std::memcpy(dst + 3 * i, &v, sizeof v);
                continue;
            }
            for (int c = 0; c < 3; ++c)
                dst[3 * i + c] = wt[0] * src[idx[0] + c] + wt[1] * src[idx[1] + c] + wt[2] * src[idx[2] + c] +
                                 wt[3] * src[idx[3] + c];
        }
    };
    constexpr int kBandRows = 16;
    const int bands = (out.height + kBandRows - 1) / kBandRows;
    const std::size_t row_floats = 3 * std::size_t(out.width);
    HdrImage result(out.width, out.height, HdrImage::Unwritten{});
    std::atomic<long long> negative{0};
    parallel_for(bands, threads, [&](int band) {
        const int j0 = band * kBandRows, j1 = std::min(out.height, j0 + kBandRows);
        // Continued input rows first .. last (past the poles: rows mirrored and turned).
        const int first = cubic_tap(j0, out.height, h).first, last = cubic_tap(j1 - 1, out.height, h).first + 3;
        thread_local std::vector<float> across;  // rows first .. last resampled across
        thread_local std::vector<float> turned;
        across.resize(std::size_t(last - first + 1) * row_floats + 1);  // + 1: across_row's last store
        for (int k = first; k <= last; ++k) {
            // Past a pole: the resampled row turned half a turn of the output's columns, as
            // continued_row turns a row of a map as wide as the output.
            const RowTap t = row_across_pole(k, h, out.width);
            float* dst = across.data() + std::size_t(k - first) * row_floats;
            across_row(t.row, dst);
            if (t.shift == 0) continue;
            turned.assign(dst, dst + row_floats);
            copy_turned(turned.data(), out.width, t.shift, dst);
        }
        long long below = 0;
        for (int j = j0; j < j1; ++j) {
            const Tap t = cubic_tap(j, out.height, h);
            std::array<const float*, 4> rows;
            for (int k = 0; k < 4; ++k)
                rows[std::size_t(k)] = across.data() + std::size_t(t.first + k - first) * row_floats;
            const std::array<float, 4> wt = {float(t.weight[0]), float(t.weight[1]), float(t.weight[2]),
                                             float(t.weight[3])};
            float* dst = result.row(j);
            below += blend_rows(rows, wt, row_floats, dst);
            if (lobes) lobes->apply_row(j, dst);
        }
        negative += below;
    });
    if (clamped) *clamped += negative.load();
    return result;
}

BrightLobes::BrightLobes(const std::vector<BrightTexel>& bright, double n, Size out, double floor_value, LobeOp op)
    // The weights here are the lobe's own, max(0, r.w_b)^n (cmax = 1): the cut needs no allowance.
    // 1e-6 a texel up to 1000 texels. Terms added back summed in float: the weights are at
    // most 1 and the sums go into float maps. N terms in float round by at most N/2^24 of their
    // sum, in practice about sqrt(N) of that: the tiles of a 4096x2048 photograph's lamps,
    // thousands of terms a texel, came within 1.2e-5 (worst texel) of the double sums
    // (2026-12-07). Subtracted terms stay in double: what is left is a remainder far dimmer
    // than the lobes near a lamp, and the lookup estimates difference it.
    : scatter_(bright, n, out, floor_value, 1e-3, 1.0, op != LobeOp::Subtract),
      norm_((op == LobeOp::Subtract ? -1.0 : 1.0) * (n + 1.0) / kTwoPi),
      op_(op),
      reached_(scatter_.rows_reached()) {}

void BrightLobes::apply_row(int row, float* dst) const {
    if (!reached_[std::size_t(row)]) return;
    const int width = 3 * scatter_.grid().width;
    thread_local std::vector<double> sums;
    sums.assign(std::size_t(width), 0.0);
    const double one = 1.0;
    scatter_.add_row(row, &one, 1, sums.data());
    for (int i = 0; i < width; ++i) {
        const float v = float(double(dst[i]) + norm_ * sums[std::size_t(i)]);
        dst[i] = op_ == LobeOp::AddClamped ? std::max(0.0f, v) : v;
    }
}

void BrightLobes::apply_runs(int row, const LobeSummer::ColumnRuns& runs, int first_column, int count,
                             float* dst) const {
    if (!reached_[std::size_t(row)] || runs.empty()) return;
    thread_local std::vector<double> sums;
    sums.resize(3 * std::size_t(count));
    for (const auto& [a, b] : runs)  // add_row writes the runs' texels only
        std::fill(sums.begin() + 3 * (a - first_column), sums.begin() + 3 * (b - first_column), 0.0);
    const double one = 1.0;
    scatter_.add_row(row, &one, 1, sums.data(), &runs, first_column);
    for (const auto& [a, b] : runs)
        for (int k = 3 * (a - first_column); k < 3 * (b - first_column); ++k) {
            const float v = float(double(dst[k]) + norm_ * sums[std::size_t(k)]);
            dst[k] = op_ == LobeOp::AddClamped ? std::max(0.0f, v) : v;
        }
}

void add_bright_lobes(const std::vector<BrightTexel>& bright, double n, double floor_value, LobeOp op,
                      HdrImage& map, int threads) {
    if (bright.empty()) return;
    const BrightLobes lobes(bright, n, {map.width(), map.height()}, floor_value, op);
    parallel_for(map.height(), threads, [&](int j) { lobes.apply_row(j, map.row(j)); });
}

HdrImage filter_to_footprint(const HdrImage& env, Size out, int threads) {
    const int w = env.width(), h = env.height();
    if (out.width == w && out.height == h) return env;
    // Pass 1, azimuth: each output column averages the input columns it overlaps, by overlap
    // length (texels of one row share their solid angle).
    struct Span {
        int first;
        std::vector<double> weight;
    };
    const auto spans = [](int out_count, int in_count) {
        std::vector<Span> s(static_cast<std::size_t>(out_count));
        for (int o = 0; o < out_count; ++o) {
            const double a = double(o) * in_count / out_count, b = double(o + 1) * in_count / out_count;
            const int first = std::min(int(std::floor(a)), in_count - 1);
            const int last = std::min(int(std::ceil(b)) - 1, in_count - 1);
            s[std::size_t(o)].first = first;
            for (int k = first; k <= last; ++k)
                s[std::size_t(o)].weight.push_back(std::max(0.0, std::min(b, k + 1.0) - std::max(a, double(k))));
        }
        return s;
    };
    const std::vector<Span> cols = spans(out.width, w);
    HdrImage across(out.width, h);
    parallel_for(h, threads, [&](int j) {
        for (int i = 0; i < out.width; ++i) {
            const Span& s = cols[std::size_t(i)];
            double v[3] = {0, 0, 0}, total = 0;
            for (std::size_t k = 0; k < s.weight.size(); ++k) {
                const float* p = env.row(j) + 3 * (s.first + int(k));
                for (int c = 0; c < 3; ++c) v[c] += s.weight[k] * p[c];
                total += s.weight[k];
            }
            for (int c = 0; c < 3; ++c) across.row(j)[3 * i + c] = float(v[c] / total);
        }
    });
    // Pass 2, polar angle: each output row averages the input rows it overlaps, by the solid
    // angle of the overlap (cos a - cos b of its polar-angle interval).
    HdrImage result(out.width, out.height);
    parallel_for(out.height, threads, [&](int j) {
        const double a = kPi * j / out.height, b = kPi * (j + 1) / out.height;
        const int first = std::min(int(std::floor(double(j) * h / out.height)), h - 1);
        const int last = std::min(int(std::ceil(double(j + 1) * h / out.height)) - 1, h - 1);
        std::vector<double> v(std::size_t(3 * out.width), 0.0);
        double total = 0;
        for (int k = first; k <= last; ++k) {
            const double lo = std::max(a, kPi * k / h), hi = std::min(b, kPi * (k + 1) / h);
            if (hi <= lo) continue;
            const double weight = std::cos(lo) - std::cos(hi);
            const float* p = across.row(k);
            for (int i = 0; i < 3 * out.width; ++i) v[std::size_t(i)] += weight * p[i];
            total += weight;
        }
        float* dst = result.row(j);
        for (int i = 0; i < 3 * out.width; ++i) dst[i] = total > 0 ? float(v[std::size_t(i)] / total) : 0.0f;
    });
    return result;
}

}  // namespace glint::convolution
