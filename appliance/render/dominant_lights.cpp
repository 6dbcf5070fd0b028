#include "appliance/render/dominant_lights.hpp"

#include <algorithm>
#include <cmath>
#include <string>

#include "appliance/core/equirect.hpp"
#include "appliance/core/errors.hpp"

namespace glint::render {
namespace {

double luminance(const float* rgb) { return 0.2126 * rgb[0] + 0.7152 * rgb[1] + 0.0722 * rgb[2]; }

// The integral of the unit direction over a texel of row j, split into what is shared by the row
// (radial part A s, vertical part B dphi) and the column's azimuth:
//   int d dOmega = ( A s sin(phi_c),  B dphi,  -A s cos(phi_c) ),
//   A = int sin^2 theta dtheta,  B = int sin theta cos theta dtheta over the row's theta range,
//   s = 2 sin(dphi / 2) = int cos(phi - phi_c) dphi over the column.
struct RowMoments {
    double radial = 0;    // A s
    double vertical = 0;  // B dphi
};

std::vector<RowMoments> row_moments(int width, int height) {
    std::vector<RowMoments> out(static_cast<std::size_t>(height));
    const double dphi = kTwoPi / width;
    const double s = 2.0 * std::sin(dphi / 2.0);
    for (int j = 0; j < height; ++j) {
        const double t0 = kPi * j / height, t1 = kPi * (j + 1) / height;
        const double a = (t1 - t0) / 2.0 - (std::sin(2.0 * t1) - std::sin(2.0 * t0)) / 4.0;
        const double b = (std::sin(t1) * std::sin(t1) - std::sin(t0) * std::sin(t0)) / 2.0;
        out[std::size_t(j)] = {a * s, b * dphi};
    }
    return out;
}

}  // namespace

double DominantLight::angular_radius() const {
    return std::acos(std::clamp(1.0 - solid_angle / kTwoPi, -1.0, 1.0));
}

glm::dvec3 irradiance_on(const HdrImage& environment, const glm::dvec3& normal) {
    const int w = environment.width(), h = environment.height();
    const std::vector<double> domega = row_solid_angles(w, h);
    glm::dvec3 sum(0.0);
    for (int j = 0; j < h; ++j) {
        const float* row = environment.row(j);
        for (int i = 0; i < w; ++i) {
            const double c = glm::dot(normal, texel_direction(i, j, w, h));
            if (c <= 0) continue;
            sum += glm::dvec3(row[3 * i], row[3 * i + 1], row[3 * i + 2]) * (c * domega[std::size_t(j)]);
        }
    }
    return sum;
}

LightDecomposition find_dominant_lights(const HdrImage& environment, const DominantLightOptions& options) {
    if (environment.empty()) throw InputError("dominant lights: the environment map is empty");
    if (options.max_lights < 0) throw InputError("dominant lights: max_lights must not be negative");
    if (!(options.grow_ratio > 0 && options.seed_ratio >= options.grow_ratio))
        throw InputError("dominant lights: want 0 < grow_ratio <= seed_ratio");

    const int w = environment.width(), h = environment.height();
    const std::vector<double> domega = row_solid_angles(w, h);
    const std::vector<RowMoments> moments = row_moments(w, h);
    std::vector<double> lum(environment.texel_count());
    double total = 0;
    for (int j = 0; j < h; ++j)
        for (int i = 0; i < w; ++i) {
            const double l = std::max(0.0, luminance(environment.row(j) + 3 * i));
            lum[std::size_t(j) * std::size_t(w) + std::size_t(i)] = l;
            total += l * domega[std::size_t(j)];
        }

    LightDecomposition out;
    out.mean_luminance = total / (2.0 * kTwoPi);
    out.ambient = environment;
    if (!(total > 0) || options.max_lights == 0) return out;
    const double seed = options.seed_ratio * out.mean_luminance;
    const double grow = options.grow_ratio * out.mean_luminance;

    struct Region {
        std::vector<std::size_t> texels;
        double energy = 0;  // luminance times solid angle
    };
    std::vector<Region> regions;
    std::vector<char> visited(lum.size(), 0);
    // Seeds brightest first, so each region starts at its own peak and its core threshold is known.
    std::vector<std::size_t> seeds;
    for (std::size_t k = 0; k < lum.size(); ++k)
        if (lum[k] > seed) seeds.push_back(k);
    std::sort(seeds.begin(), seeds.end(), [&](std::size_t a, std::size_t b) { return lum[a] > lum[b]; });
    auto neighbours = [&](std::size_t k, const auto& visit) {
        const int i = int(k % std::size_t(w)), j = int(k / std::size_t(w));
        auto at = [&](int ni, int nj) {
            ni = ((ni % w) + w) % w;  // the seam: column W-1 touches column 0
            visit(std::size_t(nj) * std::size_t(w) + std::size_t(ni));
        };
        for (int dj = -1; dj <= 1; ++dj) {
            const int nj = j + dj;
            if (nj < 0 || nj >= h) continue;
            for (int di = -1; di <= 1; ++di)
                if (di != 0 || dj != 0) at(i + di, nj);
        }
        // Across the pole: the first and last rows meet the texel half a turn away.
        if (j == 0 || j == h - 1) at(i + w / 2, j);
    };
    std::vector<std::size_t> stack;
    for (const std::size_t start : seeds) {
        if (visited[start]) continue;
        const double core = std::max(grow, options.core_fraction * lum[start]);
        Region region;
        visited[start] = 1;
        stack.assign(1, start);
        while (!stack.empty()) {
            const std::size_t k = stack.back();
            stack.pop_back();
            region.texels.push_back(k);
            neighbours(k, [&](std::size_t n) {
                if (visited[n] || !(lum[n] > core)) return;
                visited[n] = 1;
                stack.push_back(n);
            });
        }
        // One ring more above the grow threshold: the partly covered texels at the core's rim.
        const std::size_t core_size = region.texels.size();
        for (std::size_t c = 0; c < core_size; ++c)
            neighbours(region.texels[c], [&](std::size_t n) {
                if (visited[n] || !(lum[n] > grow)) return;
                visited[n] = 1;
                region.texels.push_back(n);
            });
        for (const std::size_t k : region.texels) region.energy += lum[k] * domega[k / std::size_t(w)];
        regions.push_back(std::move(region));
    }
    std::sort(regions.begin(), regions.end(), [](const Region& a, const Region& b) { return a.energy > b.energy; });

    for (const Region& region : regions) {
        if (int(out.lights.size()) >= options.max_lights) break;
        if (region.energy < options.min_energy_share * total) break;
        DominantLight light;
        glm::dvec3 moment(0.0);
        double weight = 0, peak = 0;
        for (const std::size_t k : region.texels) {
            const int i = int(k % std::size_t(w)), j = int(k / std::size_t(w));
            const float* p = environment.row(j) + 3 * i;
            const double dw = domega[std::size_t(j)];
            light.energy += glm::dvec3(p[0], p[1], p[2]) * dw;
            const double phi = column_phi(i, w);
            const RowMoments& m = moments[std::size_t(j)];
            moment += lum[k] * glm::dvec3(m.radial * std::sin(phi), m.vertical, -m.radial * std::cos(phi));
            weight += lum[k] * dw;
            peak = std::max(peak, lum[k]);
        }
        const double length = glm::length(moment);
        light.direction = moment / length;
        const double mean_cos = std::clamp(length / weight, -1.0, 1.0);
        // The spread's disc is too wide by the texels' own footprint at the rim (a partly covered
        // texel spreads its energy over its whole area), a third or more for a light a few texels
        // across; energy over peak luminance is the solid angle at the core's radiance, exact for a
        // uniform light with one fully covered texel. The smaller of the two.
        light.solid_angle = std::min(2.0 * kTwoPi * (1.0 - mean_cos), weight / peak);
        light.radiance = light.energy / light.solid_angle;
        light.texels = int(region.texels.size());
        // Wholly behind the surface that the caller lights: it stays in the ambient part.
        if (light.angular_radius() > options.max_angular_radius) continue;
        if (options.facing) {
            if (glm::dot(light.direction, *options.facing) <= -std::sin(light.angular_radius())) continue;
            glm::dvec3 towards(0.0);
            for (const std::size_t k : region.texels) {
                const int i = int(k % std::size_t(w)), j = int(k / std::size_t(w));
                const glm::dvec3 d = texel_direction(i, j, w, h);
                const double c = glm::dot(d, *options.facing);
                if (c <= 0) continue;
                const float* p = environment.row(j) + 3 * i;
                light.facing_irradiance += glm::dvec3(p[0], p[1], p[2]) * (c * domega[std::size_t(j)]);
                towards += (lum[k] * c * domega[std::size_t(j)]) * d;
            }
            light.facing_direction = glm::length(towards) > 0 ? glm::normalize(towards) : light.direction;
        }
        for (const std::size_t k : region.texels) {
            float* a = out.ambient.row(int(k / std::size_t(w))) + 3 * (k % std::size_t(w));
            a[0] = a[1] = a[2] = 0.0f;
        }
        out.lights.push_back(light);
    }
    return out;
}

}  // namespace glint::render
