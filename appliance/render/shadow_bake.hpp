// The table's shadow baked by ray casting against the real mesh (docs/render.md, "Baked shadows"):
// for the points of a grid on the table around the object, the visible part of each dominant
// light's disc and the share of the ambient irradiance the mesh leaves, from Embree rays
// (occlusion_scene.hpp). The shader (render_shadow.glsl) looks them up bilinearly inside the grid
// and forms the same ratio as the analytic path,
//   ratio = (sum_i E_i V_i + E_a left) / (sum_i E_i + E_a),
// where a mesh would otherwise be seen as a lattice of spheres (shadow.hpp, occluder_spheres): too
// dark by 0.08 on average for a box. Outside the grid the analytic spheres remain.
#pragma once

#include <vector>

#include <glm/glm.hpp>

#include "appliance/render/mesh.hpp"
#include "appliance/render/shadow.hpp"

namespace glint::render {

struct ShadowBakeOptions {
    int resolution = 128;       // grid points along each side
    int light_rays = 64;        // per light and point, stratified over the light's disc
    int ambient_subsamples = 2; // per side of each texel of the 64x32 ambient map (2: 4 rays a texel)
    // The grid's half side, in bounding radii of the mesh: at least min (contact occlusion beyond
    // 4 radii takes under 1 % of the sky), out to where the lights' shadows reach, at most max.
    double min_half_size = 4, max_half_size = 8;
    int threads = 0;            // 0 = all cores
};

struct ShadowBake {
    int resolution = 0;
    double table_height = 0;
    glm::dvec2 origin{0.0};  // (x, z) of grid point (0, 0); point (i, j) is origin + (i, j) * spacing
    double spacing = 0;
    // Per point (row j = z index, column i = x index), 4 floats: V_i of lights 0..3 (1 = fully
    // visible; 1 for lights that do not exist).
    std::vector<float> lights;
    // Per point, 4 floats: RGB = the share of the ambient irradiance left (1 - O_a / E_a), A = 1.
    std::vector<float> ambient;
    // Beyond the grid the table is open: every light's shadow of the mesh, penumbra included,
    // ends inside it, and the grid reaches 4 bounding radii, past which the mesh hides under 1 %
    // of the sky. The display then draws the shadow from the grid alone (render_shadow.glsl's
    // SHADOW_BAKE_ONLY: the analytic spheres' code, which cost 15 ms of a 17 ms composite at
    // 320x180 on llvmpipe, is compiled out); else the spheres model the table beyond it.
    bool open_beyond = false;
    long long rays = 0;      // traced (rays the bound's cone excludes are not)
    double seconds = 0;
};

// A bake that hides nothing (every light visible, all the ambient left) on a grid of
// `resolution` points a side: the kiosk binds it during its warm-up so that the driver compiles
// the baked shadow's shaders before a visitor's frame needs them (with open_beyond either way).
ShadowBake unshadowed_bake(int resolution, double table_height, bool open_beyond = true);

// Whether a grid of half side `half` around a mesh of bounding radius `radius`, whose top stands
// `top` above the table, holds every light's shadow (ShadowBake::open_beyond).
bool shadow_grid_holds_every_shadow(const ShadowLighting& lighting, double radius, double top, double half);

// Throws InputError for a mesh without triangles, RuntimeError when Embree fails.
ShadowBake bake_table_shadow(const Mesh& mesh, const ShadowLighting& lighting, double table_height,
                             const ShadowBakeOptions& options = {});

}  // namespace glint::render
