// Per-vertex ambient occlusion baked with Embree (docs/render.md, "Ambient occlusion"): the
// fraction of a vertex's cosine-weighted hemisphere (about its normal) from which a ray reaches
// beyond a maximum distance without hitting the model. 1 = open, 0 = fully enclosed. It is what
// the shading multiplies into the diffuse term: L = kd E_d(N) ao + ks E_s^n(R).
#pragma once

#include <cstddef>
#include <cstdint>
#include <functional>
#include <vector>

#include "appliance/render/mesh.hpp"

namespace glint::render {

struct AoBakeOptions {
    int rays = 256;  // per vertex
    // Hits farther than this times the model's bounding-sphere radius (about its bounding box's
    // centre, as normalise_to_unit_sphere) do not occlude. The default, 2 (the sphere's diameter),
    // is no limit at all: no two points of the model are farther apart, so every part of the model
    // that blocks the distant environment counts, which is what E_d's lighting from infinity asks
    // for. Smaller values give the "local" look of a short reach (the inside of a vessel lighter).
    double max_distance_relative = 2.0;
    // Rays start this far (times the radius) off the surface along the vertex normal, so that
    // they do not hit the triangles around their own vertex through rounding.
    double offset_relative = 1e-4;
    int threads = 0;  // 0 = all cores
    // Called with (vertices done, total) from worker threads, after each block of vertices.
    std::function<void(std::size_t, std::size_t)> progress;
};

// One ao value per vertex of `mesh`, in [0, 1]. Rays for a vertex are seeded by its position and
// normal, so vertices duplicated along seams (the same point and normal) get the same value.
// Throws RuntimeError when Embree fails, InputError for an empty mesh or options out of range.
std::vector<float> bake_ambient_occlusion(const Mesh& mesh, const AoBakeOptions& options = {});

// The cosine-weighted directions a vertex uses, in the frame where the normal is +Z: ray k of
// `rays`, with the per-vertex shift (sx, sy) in [0, 1)^2 (a Hammersley set, shifted modulo 1).
// Exposed for the tests.
void cosine_direction(int k, int rays, double sx, double sy, double out[3]);

}  // namespace glint::render
