// The Newell teapot, the default model of `glint render --model teapot` (docs/render.md, "Models").
//
// Martin Newell's 1975 teapot: 32 bicubic Bezier patches over 306 control points (rim 4, body 8,
// handle 4, spout 4, lid 8, bottom 4). The data is in the public domain; the table in teapot.cpp
// is the widely published set (as in Crow, "The Origins of the Teapot", IEEE CG&A 7(1), 1987).
// The tessellation and normals are ours.
#pragma once

#include <array>
#include <cstddef>
#include <vector>

#include <glm/glm.hpp>

#include "appliance/render/mesh.hpp"

namespace glint::render {

// Default tessellation level: 16 quads along each patch edge, 16 256 triangles.
inline constexpr int kTeapotDefaultLevel = 16;

// The teapot tessellated into `level` x `level` quads per patch (level >= 1), two triangles a
// quad, except where a patch edge collapses to a point (the lid's knob top and the bottom's
// centre), where the triangle that would have two equal corners is left out:
//   triangles = 64 level^2 - 8 level        (level 40: 102 080, the benchmark's ~100k model)
// In Glint's frame (+Y up; the data is Z up): (x, y, z)_Newell -> (x, z, -y), so the spout points
// to +X and the camera on +Z sees the teapot from the side. Not normalised: it stands on y = 0,
// 3.15 units tall; normalise_to_unit_sphere as for any model. Normals are the exact surface normals
// from the patch derivatives, pointing out of the pot; vertices are not shared between patches.
Mesh make_teapot(int level = kTeapotDefaultLevel);

// The triangle count make_teapot(level) gives.
std::size_t teapot_triangle_count(int level);

// A per-vertex field of make_teapot(from_level) (ambient occlusion, say) resampled onto the
// vertices of make_teapot(to_level): bilinear in each patch's (u, v), which both tessellations
// share. Lets a bake on a coarse teapot serve a fine one (docs/render.md, "Ambient occlusion").
// Throws InputError when `values` is not one per vertex of from_level.
std::vector<float> resample_teapot_field(const std::vector<float>& values, int from_level, int to_level);

// The raw data, for the tests: 306 control points (Newell's Z-up frame) and, per patch, the 16
// control-point indices (0-based) in row-major order (4 rows in v of 4 points in u).
const std::array<glm::dvec3, 306>& teapot_control_points();
const std::array<std::array<int, 16>, 32>& teapot_patches();

}  // namespace glint::render
