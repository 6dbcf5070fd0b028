#include "appliance/render/ao_bake.hpp"

#include "appliance/render/occlusion_scene.hpp"
#include "appliance/render/sampling.hpp"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstring>
#include <limits>
#include <string>

#include "appliance/core/equirect.hpp"
#include "appliance/core/errors.hpp"
#include "appliance/core/parallel.hpp"

namespace glint::render {
namespace {

// SplitMix64: a well-mixed 64-bit hash, for seeding a vertex's rays from its position and normal.
std::uint64_t mix(std::uint64_t x) {
    x += 0x9e3779b97f4a7c15ull;
    x = (x ^ (x >> 30)) * 0xbf58476d1ce4e5b9ull;
    x = (x ^ (x >> 27)) * 0x94d049bb133111ebull;
    return x ^ (x >> 31);
}

std::uint64_t bits_of(float f) {
    std::uint32_t u;
    std::memcpy(&u, &f, sizeof u);
    return u;
}

double unit_of(std::uint64_t h) { return double(h >> 11) * 0x1.0p-53; }

}  // namespace

void cosine_direction(int k, int rays, double sx, double sy, double out[3]) {
    // Malley's method: a uniform point on the unit disc, lifted to the hemisphere, is
    // cosine-distributed. Disc by the area-preserving polar map of (u1, u2).
    double u1 = (k + 0.5) / rays + sx, u2 = radical_inverse(std::uint32_t(k)) + sy;
    u1 -= std::floor(u1);
    u2 -= std::floor(u2);
    const double r = std::sqrt(u1), phi = kTwoPi * u2;
    out[0] = r * std::cos(phi);
    out[1] = r * std::sin(phi);
    out[2] = std::sqrt(std::max(0.0, 1.0 - u1));
}

std::vector<float> bake_ambient_occlusion(const Mesh& mesh, const AoBakeOptions& options) {
    if (mesh.positions.empty() || mesh.indices.empty()) throw InputError("ao bake: the mesh " + mesh.source + " has no triangles");
    if (options.rays < 1 || options.rays > (1 << 20)) throw InputError("ao bake: rays must be in [1, 1048576]");
    if (!(options.max_distance_relative > 0)) throw InputError("ao bake: the maximum distance must be positive");
    if (mesh.normals.size() != mesh.positions.size()) throw InputError("ao bake: the mesh " + mesh.source + " has no normal per vertex");

    // The model's size: the bounding sphere about its bounding box's centre.
    const double radius = mesh_bounds(mesh).radius;
    if (!(radius > 0)) throw InputError("ao bake: the mesh " + mesh.source + " has no extent");
    const float max_distance = float(options.max_distance_relative * radius);
    const double offset = options.offset_relative * radius;

    const OcclusionScene scene(mesh, "ao bake");

    const std::size_t count = mesh.positions.size();
    std::vector<float> ao(count, 1.0f);
    constexpr std::size_t kBlock = 256;
    const int blocks = int((count + kBlock - 1) / kBlock);
    std::atomic<std::size_t> done{0};
    const int threads = options.threads > 0 ? options.threads : hardware_threads();
    parallel_for(blocks, threads, [&](int block) {
        std::vector<RTCRay> rays;
        const std::size_t begin = std::size_t(block) * kBlock, end = std::min(count, begin + kBlock);
        for (std::size_t v = begin; v < end; ++v) {
            const glm::vec3 p = mesh.positions[v];
            glm::dvec3 n(mesh.normals[v]);
            const double len = glm::length(n);
            if (!(len > 0)) continue;  // no normal, no hemisphere: left open
            n /= len;
            glm::dvec3 t, b;
            orthonormal_basis(n, t, b);
            std::uint64_t h = 0;
            for (float f : {p.x, p.y, p.z, mesh.normals[v].x, mesh.normals[v].y, mesh.normals[v].z}) h = mix(h ^ bits_of(f));
            const double sx = unit_of(h), sy = unit_of(mix(h));
            const glm::dvec3 origin = glm::dvec3(p) + offset * n;
            // All of a vertex's rays in one stream: they share an origin, so Embree traces them
            // in packets: twice as fast as one rtcOccluded1 a ray here (docs/render.md, "Speed").
            rays.resize(std::size_t(options.rays));
            for (int k = 0; k < options.rays; ++k) {
                double l[3];
                cosine_direction(k, options.rays, sx, sy, l);
                const glm::dvec3 d = l[0] * t + l[1] * b + l[2] * n;
                rays[std::size_t(k)] = OcclusionScene::ray(origin, d, 0.0f, max_distance, unsigned(k));
            }
            scene.trace(rays);
            int open = 0;
            for (const RTCRay& ray : rays) open += !OcclusionScene::occluded(ray);
            ao[v] = float(double(open) / options.rays);
        }
        const std::size_t now = done.fetch_add(end - begin) + (end - begin);
        if (options.progress) options.progress(now, count);
    });
    scene.check("tracing the rays");
    return ao;
}

}  // namespace glint::render
