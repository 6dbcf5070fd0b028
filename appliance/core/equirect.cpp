// Equirectangular conventions: directions, texels, exact solid angles, bilinear lookup.
#include "appliance/core/equirect.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include "appliance/core/parallel.hpp"

namespace glint {

glm::dvec3 direction_from_angles(double theta, double phi) {
    const double st = std::sin(theta);
    return {st * std::sin(phi), std::cos(theta), -st * std::cos(phi)};
}

glm::dvec3 texel_direction(int i, int j, int width, int height) {
    return direction_from_angles(row_theta(j, height), column_phi(i, width));
}

TexelCoord direction_to_texel(const glm::dvec3& d, int width, int height) {
    const double phi = std::atan2(d.x, -d.z);                 // in [-pi, pi]
    const double theta = std::acos(std::clamp(d.y, -1.0, 1.0));  // in [0, pi]
    double x = (phi + kPi) / kTwoPi * width;
    if (x >= width) x -= width;  // phi = +pi is the same column as phi = -pi
    if (x < 0) x += width;
    return {x, theta / kPi * height};
}

double row_solid_angle(int j, int width, int height) {
    // cos(a) - cos(b) = 2 sin((a+b)/2) sin((b-a)/2): no cancellation near the poles.
    const double a = kPi * j / height;
    const double b = kPi * (j + 1) / height;
    return (kTwoPi / width) * 2.0 * std::sin(0.5 * (a + b)) * std::sin(0.5 * (b - a));
}

std::vector<double> row_solid_angles(int width, int height) {
    std::vector<double> out(static_cast<std::size_t>(height));
    for (int j = 0; j < height; ++j) out[std::size_t(j)] = row_solid_angle(j, width, height);
    return out;
}

Rgb sample_bilinear(const HdrImage& image, const glm::dvec3& d) {
    const int w = image.width();
    const int h = image.height();
    const TexelCoord t = direction_to_texel(d, w, h);
    // Texel centres sit at half-integers; shift so that integer coordinates are centres.
    const double x = t.x - 0.5;
    const double y = std::clamp(t.y - 0.5, 0.0, double(h - 1));
    const double fx0 = std::floor(x);
    const double fy0 = std::floor(y);
    const double ax = x - fx0;
    const double ay = y - fy0;
    int x0 = int(fx0) % w;
    if (x0 < 0) x0 += w;
    const int x1 = (x0 + 1) % w;
    const int y0 = int(fy0);
    const int y1 = std::min(y0 + 1, h - 1);
    const float* r0 = image.row(y0);
    const float* r1 = image.row(y1);
    float v[3];
    for (int c = 0; c < 3; ++c) {
        const double top = (1 - ax) * r0[3 * x0 + c] + ax * r0[3 * x1 + c];
        const double bottom = (1 - ax) * r1[3 * x0 + c] + ax * r1[3 * x1 + c];
        v[c] = float((1 - ay) * top + ay * bottom);
    }
    return {v[0], v[1], v[2]};
}

Rgb sample_lobe(const HdrImage& image, const glm::dvec3& d_in, double n, double span) {
    const int w = image.width();
    const int h = image.height();
    const glm::dvec3 d = glm::normalize(d_in);
    const double theta_r = std::atan2(std::sqrt(d.x * d.x + d.z * d.z), d.y);
    const double phi_r = std::atan2(d.x, -d.z);
    const double sin_r = std::sin(theta_r);
    const double dphi = kTwoPi / w;
    // hav(angle between d and a texel centre) = sin^2(dtheta/2) + sin(theta_r) sin(theta_k) sin^2(dphi/2):
    // no cancellation for the small angles a narrow lobe spans.
    const auto sq = [](double x) { return x * x; };
    const auto hav = [&](double theta_k, double sin_k, double phi_k) {
        return sq(std::sin(0.5 * (theta_r - theta_k))) + sin_r * sin_k * sq(std::sin(0.5 * (phi_r - phi_k)));
    };
    // The texel the direction falls in bounds the nearest centre's haversine; a texel whose
    // weight is below exp(-span) of that one's has hav > h0 + span / (2n), because
    // n log(cos_k / cos_0) <= -2n (hav_k - hav_0) (log(1 - x) falls at least as fast as -x).
    const TexelCoord t = direction_to_texel(d, w, h);
    int i0 = int(std::floor(t.x)) % w;
    if (i0 < 0) i0 += w;
    const int j0 = std::clamp(int(std::floor(t.y)), 0, h - 1);
    const double h0 = hav(row_theta(j0, h), std::sin(row_theta(j0, h)), column_phi(i0, w));
    const double reach = std::min(1.0, h0 + span / (2.0 * n));
    const double max_dtheta = 2.0 * std::asin(std::sqrt(reach));
    const int j_lo = std::max(0, int(std::floor((theta_r - max_dtheta) / kPi * h - 0.5)));
    const int j_hi = std::min(h - 1, int(std::ceil((theta_r + max_dtheta) / kPi * h - 0.5)));
    struct Tap {
        double log_weight;
        const float* value;
    };
    // log(1 - x) for the taps' x = 2 hav <= 2 reach: for a narrow lobe x stays under 0.05, where
    // 13 terms of its series reach double rounding (the first left out, x^14 / 14, is under 1e-18
    // of x there) at a third of log1p's cost; wider reaches take log1p.
    const bool series = 2.0 * reach < 0.05;
    const auto log1p_minus = [series](double x) {
        if (!series) return std::log1p(-x);
        double sum = 1.0 / 13.0;
        for (int k = 12; k >= 1; --k) sum = 1.0 / k + x * sum;
        return -x * sum;
    };
    constexpr int kReseed = 64;
    const double step_sin = std::sin(0.5 * dphi), step_cos = std::cos(0.5 * dphi);
    static thread_local std::vector<Tap> taps;
    taps.clear();
    double best = -std::numeric_limits<double>::infinity();
    for (int j = j_lo; j <= j_hi; ++j) {
        const double theta_k = row_theta(j, h), sin_k = std::sin(theta_k);
        const double rest = reach - sq(std::sin(0.5 * (theta_r - theta_k)));
        if (rest < 0) continue;
        const double across = sin_r * sin_k;
        int i_lo = 0, count = w;
        if (across > rest) {  // not every column of the row is near enough
            const double max_dphi = 2.0 * std::asin(std::sqrt(rest / across));
            i_lo = int(std::floor((phi_r - max_dphi + kPi) / dphi - 0.5));
            count = std::min(w, int(std::ceil((phi_r + max_dphi + kPi) / dphi - 0.5)) - i_lo + 1);
        }
        const double log_omega = std::log(row_solid_angle(j, w, h));
        const float* row = image.row(j);
        const double along = sq(std::sin(0.5 * (theta_r - theta_k)));
        // sin(0.5 (phi_r - phi_i)) column by column by the angle-addition recurrence (phi_i steps
        // by dphi), from exact values every kReseed columns; past the seam phi_i runs on by 2 pi,
        // which turns the half angle by pi and leaves its square sine unchanged. One sine and
        // cosine per kReseed taps, no division per tap (both were half of a tap's cost).
        int i = ((i_lo % w) + w) % w;
        double hs = 0, hc = 1;
        for (int c = 0; c < count; ++c, i = i + 1 == w ? 0 : i + 1) {
            if (c % kReseed == 0) {
                const double half = 0.5 * (phi_r - column_phi(i, w));
                hs = std::sin(half);
                hc = std::cos(half);
            } else {
                const double s_next = hs * step_cos - hc * step_sin;  // half - dphi / 2
                hc = hc * step_cos + hs * step_sin;
                hs = s_next;
            }
            const double hk = along + across * hs * hs;
            if (hk > reach || hk >= 0.5) continue;  // beyond the span, or behind (d.w_k <= 0)
            const double lw = n * log1p_minus(2.0 * hk) + log_omega;
            taps.push_back({lw, row + 3 * i});
            best = std::max(best, lw);
        }
    }
    double sum[3] = {0, 0, 0}, norm = 0;
    for (const Tap& tap : taps) {
        const double wk = std::exp(tap.log_weight - best);
        norm += wk;
        for (int c = 0; c < 3; ++c) sum[c] += wk * tap.value[c];
    }
    if (!(norm > 0)) return image.at(i0, j0);
    return {float(sum[0] / norm), float(sum[1] / norm), float(sum[2] / norm)};
}

HdrImage resample_lobe(const HdrImage& image, int width, int height, double n, int threads) {
    HdrImage out(width, height);
    parallel_for(height, threads > 0 ? threads : hardware_threads(), [&](int j) {
        for (int i = 0; i < width; ++i) out.set(i, j, sample_lobe(image, texel_direction(i, j, width, height), n));
    });
    return out;
}

const char* to_string(MapLookup lookup) { return lookup == MapLookup::Lobe ? "lobe" : "bilinear"; }

std::optional<MapLookup> map_lookup_from_string(const std::string& name) {
    if (name == "bilinear") return MapLookup::Bilinear;
    if (name == "lobe") return MapLookup::Lobe;
    return std::nullopt;
}

HdrImage resample_bilinear(const HdrImage& image, int width, int height) {
    if (image.width() == width && image.height() == height) return image;
    HdrImage out(width, height);
    for (int j = 0; j < height; ++j)
        for (int i = 0; i < width; ++i)
            out.set(i, j, sample_bilinear(image, texel_direction(i, j, width, height)));
    return out;
}

}  // namespace glint
