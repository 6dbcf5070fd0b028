// The off-grid judge (offgrid.hpp): E^n(r) by the conventions' plain sum, and a
// Monte Carlo estimate of a map's bilinear-lookup error against it.
#include "appliance/convolution/offgrid.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

#include "appliance/core/equirect.hpp"
#include "appliance/core/errors.hpp"
#include "appliance/core/parallel.hpp"

namespace glint::convolution {
namespace {

// ln(1e-300): a weight relative to the largest below exp of this cannot change a
// double sum whose largest term is ~1 (it is below 1e-300 of it).
constexpr double kLogNegligible = -690.7755278982137;

void check_shininess(double n) {
    if (std::isnan(n) || n < 0)
        throw InputError("off-grid judge: shininess must be >= 0 or +infinity (a mirror), got " + std::to_string(n));
}

void check_image(const HdrImage& image, const char* what) {
    if (image.empty()) throw InputError(std::string("off-grid judge: the ") + what + " map is empty");
}

// splitmix64: one small independent stream per sample, seeded from (seed, index).
struct Stream {
    std::uint64_t state;
    Stream(std::uint64_t seed, std::uint64_t index) : state(seed) { state = next() ^ (index * 0xD1B54A32D192ED03ull); }
    std::uint64_t next() {
        std::uint64_t z = (state += 0x9E3779B97F4A7C15ull);
        z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
        z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
        return z ^ (z >> 31);
    }
    double uniform() { return double(next() >> 11) * 0x1.0p-53; }  // [0, 1)
};

}  // namespace

ExactAt::ExactAt(const HdrImage& input, double shininess)
    : input_(&input), n_(shininess), mirror_(std::isinf(shininess)), w_(input.width()), h_(input.height()) {
    check_image(input, "input");
    check_shininess(shininess);
    cos_t_.resize(std::size_t(h_));
    sin_t_.resize(std::size_t(h_));
    theta_.resize(std::size_t(h_));
    omega_.resize(std::size_t(h_));
    for (int j = 0; j < h_; ++j) {
        const double t = kPi * (j + 0.5) / h_;
        theta_[std::size_t(j)] = t;
        cos_t_[std::size_t(j)] = std::cos(t);
        sin_t_[std::size_t(j)] = std::sin(t);
        // (2 pi / W)(cos(pi j/H) - cos(pi (j+1)/H)) as a product, no cancellation at the poles.
        const double a = kPi * j / h_, b = kPi * (j + 1) / h_;
        omega_[std::size_t(j)] = (kTwoPi / w_) * 2.0 * std::sin(0.5 * (a + b)) * std::sin(0.5 * (b - a));
    }
    cos_p_.resize(std::size_t(w_));
    sin_p_.resize(std::size_t(w_));
    for (int i = 0; i < w_; ++i) {
        const double p = kTwoPi * (i + 0.5) / w_ - kPi;
        cos_p_[std::size_t(i)] = std::cos(p);
        sin_p_[std::size_t(i)] = std::sin(p);
    }
}

glm::dvec3 ExactAt::operator()(const glm::dvec3& r_in) const {
    const double len = std::sqrt(glm::dot(r_in, r_in));
    if (!(len > 0) || !std::isfinite(len)) throw InputError("off-grid judge: the lookup direction must be finite and non-zero");
    const glm::dvec3 d = r_in / len;
    if (mirror_) {
        const Rgb s = sample_bilinear(*input_, d);
        return {s.r, s.g, s.b};
    }
    // Texel direction (st sp, ct, -st cp), so r.w = st (dx sp - dz cp) + dy ct.
    auto cosine = [&](int i, int j) {
        return sin_t_[std::size_t(j)] * (d.x * sin_p_[std::size_t(i)] - d.z * cos_p_[std::size_t(i)]) +
               d.y * cos_t_[std::size_t(j)];
    };
    const double theta_r = std::acos(std::clamp(d.y, -1.0, 1.0));
    const double phi_r = std::atan2(d.x, -d.z);
    const double s_r = std::sqrt(d.x * d.x + d.z * d.z);  // sin(theta_r)
    // Column coordinate of r with centres at integers.
    const double xr = (phi_r + kPi) / kTwoPi * w_ - 0.5;
    auto wrap = [&](long long i) { return int(((i % w_) + w_) % w_); };

    // cmax: in each row the cosine falls with the azimuth distance, so the two
    // columns either side of r hold the row's largest (a third for rounding).
    const long long i_near = (long long)std::floor(xr);
    double cmax = -std::numeric_limits<double>::infinity();
    for (int j = 0; j < h_; ++j)
        for (long long i = i_near - 1; i <= i_near + 2; ++i) cmax = std::max(cmax, cosine(wrap(i), j));
    if (!(cmax > 0)) return {0, 0, 0};

    const bool whole = n_ == std::floor(n_) && n_ <= 4e18;
    const auto whole_n = whole ? std::uint64_t(n_) : 0;
    // Smallest cosine that can matter; n = 0 keeps every c > 0.
    const double c_lo = n_ > 0 ? cmax * std::exp(kLogNegligible / n_) : 0.0;
    constexpr double kSlack = 1e-12;  // rows and columns are bounded generously; each term is tested exactly

    // One contiguous run of columns [i0, i1) of row j: the cosines, the weights
    // (0 for the terms that do not take part) and the sums, each a plain loop the
    // compiler vectorises (the sums keep two sets of partial accumulators).
    thread_local std::vector<double> weight;
    weight.resize(std::size_t(w_));
    double num[3] = {0, 0, 0}, den = 0;
    auto add_run = [&](int j, int i0, int i1, double omega) {
        const double st = sin_t_[std::size_t(j)], dyct = d.y * cos_t_[std::size_t(j)];
        const double sx = st * d.x, sz = st * d.z;
        double* f = weight.data();
        const double* sp = sin_p_.data();
        const double* cp = cos_p_.data();
        const int count = i1 - i0;
        for (int t = 0; t < count; ++t) {
            const double c = (sx * sp[i0 + t] - sz * cp[i0 + t]) + dyct;
            f[t] = (c > 0 && c >= c_lo) ? c / cmax : 0.0;
        }
        if (n_ == 0) {
            for (int t = 0; t < count; ++t) f[t] = f[t] > 0 ? 1.0 : 0.0;
        } else if (n_ != 1) {
            if (whole) {
                // x^n by binary exponentiation, the same steps for every term.
                std::uint64_t e = whole_n;
                double* base = f;
                thread_local std::vector<double> result_buffer;
                result_buffer.assign(std::size_t(count), 1.0);
                double* result = result_buffer.data();
                for (;;) {
                    if (e & 1u)
                        for (int t = 0; t < count; ++t) result[t] *= base[t];
                    e >>= 1;
                    if (e == 0) break;
                    for (int t = 0; t < count; ++t) base[t] *= base[t];
                }
                std::copy(result, result + count, f);
            } else {
                for (int t = 0; t < count; ++t) f[t] = f[t] > 0 ? std::pow(std::min(f[t], 1.0), n_) : 0.0;
            }
        }
        const float* p = input_->row(j) + 3 * i0;
        double a0 = 0, a1 = 0;
        double r0 = 0, g0 = 0, b0 = 0, r1 = 0, g1 = 0, b1 = 0;
        int t = 0;
        for (; t + 1 < count; t += 2) {
            const double f0 = f[t], f1 = f[t + 1];
            a0 += f0;
            a1 += f1;
            r0 += f0 * p[3 * t];
            g0 += f0 * p[3 * t + 1];
            b0 += f0 * p[3 * t + 2];
            r1 += f1 * p[3 * t + 3];
            g1 += f1 * p[3 * t + 4];
            b1 += f1 * p[3 * t + 5];
        }
        if (t < count) {
            a0 += f[t];
            r0 += f[t] * p[3 * t];
            g0 += f[t] * p[3 * t + 1];
            b0 += f[t] * p[3 * t + 2];
        }
        num[0] += omega * (r0 + r1);
        num[1] += omega * (g0 + g1);
        num[2] += omega * (b0 + b1);
        den += omega * (a0 + a1);
    };
    for (int j = 0; j < h_; ++j) {
        // Best cosine any direction of this row can have with r.
        const double bound = std::cos(std::abs(theta_r - theta_[std::size_t(j)]));
        if (bound + kSlack <= 0 || bound + kSlack < c_lo) continue;
        const double omega = omega_[std::size_t(j)];
        // r.w = a cos(dphi) + b; the terms that pass need cos(dphi) >= q.
        const double a = s_r * sin_t_[std::size_t(j)];
        const double b = d.y * cos_t_[std::size_t(j)];
        bool whole_row = a < 1e-280;
        double half = 0;  // columns either side of xr to visit
        if (!whole_row) {
            const double q = (c_lo - b) / a - kSlack;
            if (q <= -1) whole_row = true;
            else half = (q >= 1 ? 0.0 : std::acos(q)) / kTwoPi * w_ + 1.0;
            if (2 * half + 1 >= w_) whole_row = true;
        }
        if (whole_row) {
            add_run(j, 0, w_, omega);
        } else {
            const long long first = (long long)std::ceil(xr - half);
            const long long last = (long long)std::floor(xr + half);
            if (last < first) continue;
            // [first, last] wrapped into at most two runs.
            const int f0 = wrap(first);
            const long long run = last - first + 1;
            if (f0 + run <= w_) {
                add_run(j, f0, int(f0 + run), omega);
            } else {
                add_run(j, f0, w_, omega);
                add_run(j, 0, int(f0 + run - w_), omega);
            }
        }
    }
    if (!(den > 0)) return {0, 0, 0};
    return {num[0] / den, num[1] / den, num[2] / den};
}

glm::dvec3 exact_at_double(const HdrImage& input, double shininess, const glm::dvec3& r) {
    return ExactAt(input, shininess)(r);
}

Rgb exact_at(const HdrImage& input, double shininess, const glm::dvec3& r) {
    const glm::dvec3 e = exact_at_double(input, shininess, r);
    return {float(e.x), float(e.y), float(e.z)};
}

OffGridError measure_offgrid_error(const HdrImage& input, const HdrImage& map, double shininess, int samples,
                                   std::uint64_t seed, int threads, MapLookup lookup, const FineTiles* fine) {
    check_image(input, "input");
    check_image(map, "convolved");
    check_shininess(shininess);
    if (samples < 1) throw InputError("off-grid judge: samples must be >= 1, got " + std::to_string(samples));
    if (threads <= 0) threads = hardware_threads();
    const ExactAt exact(input, shininess);

    // The importance half: texel k with probability P_k = dOmega_k |A_k|^2 / total.
    const int mw = map.width(), mh = map.height();
    const std::vector<double> map_omega = row_solid_angles(mw, mh);
    std::vector<double> cdf(map.texel_count());
    double total = 0;
    for (int j = 0; j < mh; ++j) {
        const float* p = map.row(j);
        for (int i = 0; i < mw; ++i) {
            const double v = double(p[3 * i]) * p[3 * i] + double(p[3 * i + 1]) * p[3 * i + 1] +
                             double(p[3 * i + 2]) * p[3 * i + 2];
            total += map_omega[std::size_t(j)] * v;
            cdf[std::size_t(j) * std::size_t(mw) + std::size_t(i)] = total;
        }
    }
    const bool importance = total > 0 && std::isfinite(total);
    const int n_uniform = importance ? (samples + 1) / 2 : samples;
    const double share_uniform = double(n_uniform) / samples;
    const double share_importance = 1.0 - share_uniform;
    auto texel_of = [&](const glm::dvec3& r) {
        const TexelCoord t = direction_to_texel(r, mw, mh);
        const int i = std::clamp(int(t.x), 0, mw - 1);
        const int j = std::clamp(int(t.y), 0, mh - 1);
        return std::pair<int, int>{i, j};
    };
    // Density of the mixture per steradian at r.
    auto density = [&](const glm::dvec3& r) {
        double p = share_uniform / (4 * kPi);
        if (importance) {
            const auto [i, j] = texel_of(r);
            const std::size_t k = std::size_t(j) * std::size_t(mw) + std::size_t(i);
            const double pk = (cdf[k] - (k > 0 ? cdf[k - 1] : 0.0)) / total;
            p += share_importance * pk / map_omega[std::size_t(j)];
        }
        return p;
    };

    struct Sample {
        glm::dvec3 dir, a, b;
        double p;
    };
    std::vector<Sample> s(static_cast<std::size_t>(samples));
    parallel_for(samples, threads, [&](int index) {
        Stream rng(seed, std::uint64_t(index));
        glm::dvec3 r;
        if (index < n_uniform) {
            const double y = 1.0 - 2.0 * rng.uniform();
            const double phi = kTwoPi * rng.uniform() - kPi;
            const double st = std::sqrt(std::max(0.0, 1.0 - y * y));
            r = {st * std::sin(phi), y, -st * std::cos(phi)};
        } else {
            const double target = rng.uniform() * total;
            std::size_t k = std::size_t(std::upper_bound(cdf.begin(), cdf.end(), target) - cdf.begin());
            k = std::min(k, cdf.size() - 1);
            const int i = int(k % std::size_t(mw)), j = int(k / std::size_t(mw));
            // Uniform in solid angle inside the footprint: cos(theta) uniform between the row's edges.
            const double c_top = std::cos(kPi * j / mh), c_bottom = std::cos(kPi * (j + 1) / mh);
            const double ct = c_bottom + rng.uniform() * (c_top - c_bottom);
            const double phi = kTwoPi * (i + rng.uniform()) / mw - kPi;
            r = direction_from_angles(std::acos(std::clamp(ct, -1.0, 1.0)), phi);
        }
        const Rgb a = fine && !fine->empty() && lookup == MapLookup::Bilinear ? sample_bilinear(map, *fine, r)
                                                                              : sample_map(map, r, lookup, shininess);
        Sample& out = s[std::size_t(index)];
        out.dir = r;
        out.a = {a.r, a.g, a.b};
        out.b = exact(r);
        out.p = density(r);
    });

    // Sums in sample order: independent of the thread count.
    OffGridError e;
    e.samples = samples;
    double sum_diff = 0, sum_ref = 0, sum_abs = 0;
    for (const Sample& x : s) {
        const glm::dvec3 diff = x.a - x.b;
        sum_diff += glm::dot(diff, diff) / x.p;
        sum_ref += glm::dot(x.b, x.b) / x.p;
        sum_abs += (std::abs(x.b.x) + std::abs(x.b.y) + std::abs(x.b.z)) / x.p;
    }
    e.mean_abs_reference = sum_abs / (3.0 * samples * 4 * kPi);
    if (sum_ref > 0) {
        const double ratio = sum_diff / sum_ref;
        e.weighted_relative_rms = std::sqrt(ratio);
        double var = 0;
        for (const Sample& x : s) {
            const glm::dvec3 diff = x.a - x.b;
            const double t = (glm::dot(diff, diff) - ratio * glm::dot(x.b, x.b)) / x.p;
            var += t * t;
        }
        const double ratio_se = std::sqrt(var) / sum_ref;
        e.rms_standard_error = e.weighted_relative_rms > 0 ? ratio_se / (2 * e.weighted_relative_rms) : std::sqrt(ratio_se);
    } else {
        e.weighted_relative_rms = sum_diff > 0 ? std::numeric_limits<double>::infinity() : 0.0;
    }
    for (const Sample& x : s)
        for (int c = 0; c < 3; ++c) {
            const double diff = std::abs(x.a[c] - x.b[c]);
            const double err = diff == 0 ? 0.0 : diff / std::max(std::abs(x.b[c]), e.mean_abs_reference);
            if (!(err <= e.worst_texel)) {  // NaN sticks
                e.worst_texel = err;
                e.worst_direction = x.dir;
                e.worst_channel = c;
                e.worst_approx = x.a[c];
                e.worst_reference = x.b[c];
            }
        }
    return e;
}

}  // namespace glint::convolution
