#include "appliance/render/shadow_bake.hpp"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <limits>

#include "appliance/core/equirect.hpp"
#include "appliance/core/errors.hpp"
#include "appliance/core/parallel.hpp"
#include "appliance/render/occlusion_scene.hpp"
#include "appliance/render/sampling.hpp"

namespace glint::render {
namespace {

struct Direction {
    glm::dvec3 d;
    glm::dvec3 weight;  // RGB irradiance on the table from this direction's share of the ambient
};

// How far from the mesh's centre, along the table, light l's shadow of a mesh of bounding radius
// `radius` whose top stands `top` above the table reaches: to the penumbra's far edge, where the
// mesh's top is seen against the light's lowest rim. 0 for a light wholly below the horizon (it
// lights no table point), infinity for one whose rim touches the horizon.
double shadow_reach(const DominantLight& l, double radius, double top) {
    const double beta = l.angular_radius();
    const double elevation = std::asin(std::clamp(l.direction.y, -1.0, 1.0));
    if (elevation + beta <= 0) return 0;
    const double lowest = elevation - beta;
    if (lowest <= 0) return std::numeric_limits<double>::infinity();
    return radius + top / std::tan(lowest);
}

}  // namespace

bool shadow_grid_holds_every_shadow(const ShadowLighting& lighting, double radius, double top, double half) {
    // Contact occlusion: past 4 bounding radii the mesh takes under 1 % of the sky (the grid's
    // least half side, ShadowBakeOptions::min_half_size).
    if (half < 4 * radius) return false;
    for (const DominantLight& l : lighting.lights)
        if (shadow_reach(l, radius, top) > half) return false;
    return true;
}

ShadowBake unshadowed_bake(int resolution, double table_height, bool open_beyond) {
    if (resolution < 2) throw InputError("shadow: a bake needs at least 2 points a side");
    ShadowBake b;
    b.open_beyond = open_beyond;
    b.resolution = resolution;
    b.table_height = table_height;
    b.spacing = 1.0;
    const std::size_t n = std::size_t(resolution) * std::size_t(resolution) * 4;
    b.lights.assign(n, 1.0f);
    b.ambient.assign(n, 1.0f);
    return b;
}

ShadowBake bake_table_shadow(const Mesh& mesh, const ShadowLighting& lighting, double table_height,
                             const ShadowBakeOptions& options) {
    const auto t0 = std::chrono::steady_clock::now();
    if (options.resolution < 2 || options.light_rays < 1 || options.ambient_subsamples < 1)
        throw InputError("shadow bake: resolution >= 2 and ray counts >= 1 needed");
    if (lighting.ambient_caps.empty()) throw RuntimeError("shadow bake: the lighting has no ambient map");
    const OcclusionScene scene(mesh, "shadow bake");

    // The mesh's bounding sphere: rays outside its cone from a table point cannot hit the mesh.
    const MeshBounds bounds = mesh_bounds(mesh);
    const glm::dvec3& centre = bounds.centre;
    const glm::dvec3& hi = bounds.hi;
    const double radius = std::max(bounds.radius, 1e-9);

    // The grid: around the mesh, out to where each light's shadow of the mesh's top ends, its
    // penumbra included.
    double half = options.min_half_size * radius;
    const double top = hi.y - table_height;
    for (const DominantLight& l : lighting.lights) half = std::max(half, shadow_reach(l, radius, top));
    half = std::min(half, options.max_half_size * radius);
    ShadowBake out;
    out.open_beyond = shadow_grid_holds_every_shadow(lighting, radius, top, half);
    out.resolution = options.resolution;
    out.table_height = table_height;
    out.spacing = 2 * half / (options.resolution - 1);
    out.origin = glm::dvec2(centre.x - half, centre.z - half);

    // The ambient's directions: every texel of the cap maps' level 0 (the ambient part's radiance
    // times its cosine to the table, per steradian) above the horizon, sub-sampled.
    const HdrImage& amb = lighting.ambient_caps[0];
    const int aw = amb.width(), ah = amb.height(), s = options.ambient_subsamples;
    std::vector<Direction> sky;
    glm::dvec3 sky_total(0.0);
    for (int j = 0; j < ah / 2; ++j) {
        const double c0 = std::cos(kPi * j / ah), c1 = std::cos(kPi * (j + 1) / ah);
        const double domega = row_solid_angle(j, aw, ah) / double(s * s);
        for (int i = 0; i < aw; ++i) {
            const Rgb L = amb.at(i, j);
            const glm::dvec3 w = glm::dvec3(L.r, L.g, L.b) * domega;
            if (w.x + w.y + w.z <= 0) continue;
            for (int a = 0; a < s; ++a)
                for (int b = 0; b < s; ++b) {
                    // Uniform in solid angle within the texel: cos(theta) and phi evenly spaced.
                    const double ct = c0 + (c1 - c0) * (a + 0.5) / s, st = std::sqrt(std::max(0.0, 1 - ct * ct));
                    const double phi = kTwoPi * (i + (b + 0.5) / s) / aw - kPi;
                    const glm::dvec3 d(st * std::sin(phi), ct, -st * std::cos(phi));
                    if (d.y <= 0) continue;
                    sky.push_back({d, w});
                    sky_total += w;
                }
        }
    }
    // Each light's rays: a stratified set over its disc (Hammersley, area-uniform in the tangent plane).
    const int n_lights = std::min<int>(int(lighting.lights.size()), 4);
    std::vector<std::vector<glm::dvec3>> light_dirs{std::size_t(n_lights)};
    std::vector<double> light_cone(static_cast<std::size_t>(n_lights), 0.0);
    for (int l = 0; l < n_lights; ++l) {
        const DominantLight& light = lighting.lights[std::size_t(l)];
        const glm::dvec3 n = glm::normalize(light.direction);
        const double b = light.angular_radius();
        light_cone[std::size_t(l)] = b;
        glm::dvec3 t, u;
        orthonormal_basis(n, t, u);
        for (int k = 0; k < options.light_rays; ++k) {
            const double r = b * std::sqrt((k + 0.5) / options.light_rays), phi = kTwoPi * radical_inverse(std::uint32_t(k));
            light_dirs[std::size_t(l)].push_back(std::cos(r) * n + std::sin(r) * (std::cos(phi) * t + std::sin(phi) * u));
        }
    }

    const int res = options.resolution;
    out.lights.assign(std::size_t(res) * std::size_t(res) * 4, 1.0f);
    out.ambient.assign(std::size_t(res) * std::size_t(res) * 4, 1.0f);
    std::atomic<long long> traced{0};
    const float lift = float(1e-4 * radius);  // off the table: a ray grazing the mesh's bottom face does not hit it
    parallel_for(res, options.threads > 0 ? options.threads : hardware_threads(), [&](int j) {
        std::vector<RTCRay> rays;
        std::vector<const Direction*> which;
        long long row_rays = 0;
        for (int i = 0; i < res; ++i) {
            const glm::dvec3 p(out.origin.x + i * out.spacing, table_height + lift, out.origin.y + j * out.spacing);
            const glm::dvec3 to = centre - p;
            const double dist = glm::length(to);
            const glm::dvec3 axis = to / dist;
            const double cos_cone = dist > radius ? std::sqrt(1 - (radius / dist) * (radius / dist)) : -2.0;
            const std::size_t k = 4 * (std::size_t(j) * std::size_t(res) + std::size_t(i));
            // The ambient: the rays inside the bound's cone, traced; the rest are open.
            rays.clear();
            which.clear();
            for (const Direction& d : sky)
                if (glm::dot(d.d, axis) >= cos_cone) {
                    rays.push_back(OcclusionScene::ray(p, d.d, 0.0f, 1e30f));
                    which.push_back(&d);
                }
            scene.trace(rays);
            glm::dvec3 taken(0.0);
            for (std::size_t r = 0; r < rays.size(); ++r)
                if (OcclusionScene::occluded(rays[r])) taken += which[r]->weight;
            long long count = (long long)rays.size();
            for (int c = 0; c < 3; ++c)
                out.ambient[k + std::size_t(c)] = sky_total[c] > 0 ? float(1.0 - taken[c] / sky_total[c]) : 1.0f;
            // The lights: a light whose cone misses the bound's is fully visible.
            for (int l = 0; l < n_lights; ++l) {
                const double apart = std::acos(std::clamp(glm::dot(glm::normalize(lighting.lights[std::size_t(l)].direction), axis), -1.0, 1.0));
                const double cone = dist > radius ? std::asin(radius / dist) : kPi;
                if (apart > cone + light_cone[std::size_t(l)]) continue;
                rays.clear();
                for (const glm::dvec3& d : light_dirs[std::size_t(l)]) rays.push_back(OcclusionScene::ray(p, d, 0.0f, 1e30f));
                scene.trace(rays);
                int open = 0;
                for (const RTCRay& r : rays) open += !OcclusionScene::occluded(r);
                out.lights[k + std::size_t(l)] = float(double(open) / double(rays.size()));
                count += (long long)rays.size();
            }
            row_rays += count;
        }
        traced += row_rays;
    });
    scene.check("tracing the table's rays");
    out.rays = traced.load();
    out.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    return out;
}

}  // namespace glint::render
