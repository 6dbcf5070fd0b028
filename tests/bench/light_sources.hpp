// Light sources of the capture benchmarks: the generated stress set of small, very bright
// sources (a dim and a bright room, eight discs of 1e-5 to 1e-2 sr at the poles, on the seam and
// in the open, one peak of 1e2 .. 1e6 per map), the sources found in any other map, and the energy
// a map holds around a source. Shared by bench_bright_sources.cpp and bench_capture.cpp.
#pragma once

#include <string>
#include <vector>

#include <glm/vec3.hpp>

#include "appliance/core/hdr_image.hpp"

namespace glint::bench {

// A disc on the sphere.
struct LightSource {
    glm::dvec3 dir{0, 1, 0};  // centre, world frame (conventions: +Y up)
    double radius = 0;        // rad
    double omega = 0;         // sr (2 pi (1 - cos radius) for a disc)
    double peak = 0;          // radiance inside (the stress set) or the brightest texel (found)
    std::string where;        // "pole-N", "pole-S", "seam", "open"
};

// Around a source the captured map is blurred by the camera and the registration: the energy of a
// source is counted over its disc widened by this margin.
constexpr double kSourceMarginRad = 1.5 * 3.14159265358979323846 / 180.0;

// Writes the ten stress maps (dim_1e+02 .. bright_1e+06, 2048x1024) as DIR/<name>.exr with their
// sources as DIR/<name>.sources; returns the names.
std::vector<std::string> make_stress_maps(const std::string& dir);
// The ten names, in the order make_stress_maps writes them.
std::vector<std::string> stress_map_names();

std::vector<LightSource> read_sources(const std::string& path);

// The true map box-filtered (solid-angle weighted, so each coarse texel keeps its energy) to a
// captured map's grid, when that grid is the true one halved k times; else the true map. A
// source's energy is then summed over the same texels in both: near a pole, where the disc's
// rim cuts few, large texels, the texel sets of a 2048x1024 truth and a 1024x512 capture differ
// by up to a quarter of the area (a bright room's 1e-5 sr source at the pole read +22 %).
HdrImage truth_on_grid(const HdrImage& truth, int width, int height);

// Sum of red x solid angle over the texels whose centre lies within radius + margin of the
// source's centre (the stress set's sources are white; its rooms are not). `peak`: the largest red.
double source_energy(const HdrImage& map, const LightSource& source, double margin_rad = kSourceMarginRad,
                     double* peak = nullptr);

// The compact bright sources of any map: 8-connected regions (joined across the seam, and around
// a pole) of texels whose luminance is over `factor` times the map's mean (solid-angle weighted),
// no larger than `max_omega` sr; the `max_count` with the most energy, each as the smallest disc
// about its energy-weighted centre that holds its texels' centres. Only regions with no other
// region's texel within their disc widened by kSourceMarginRad count (sources apart from the
// rest: the energy of a patch of a larger bright area cannot be told from that area's).
std::vector<LightSource> find_sources(const HdrImage& map, double factor = 20, double max_omega = 0.05,
                                      int max_count = 8);

}  // namespace glint::bench
