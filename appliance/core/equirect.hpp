// The fixed equirectangular mapping of docs/conventions.md as code.
//
//   texel (i, j), centre u = (i + 0.5) / W, v = (j + 0.5) / H, row 0 at the top
//   phi   = 2*pi*u - pi        (azimuth)      theta = pi*v (polar angle from +Y)
//   d     = ( sin(theta) sin(phi), cos(theta), -sin(theta) cos(phi) )
//   dOmega_j = (2*pi / W) * ( cos(pi*j/H) - cos(pi*(j+1)/H) )   exact, sums to 4*pi
#pragma once

#include <optional>
#include <string>

#include <glm/glm.hpp>
#include <numbers>
#include <vector>

#include "appliance/core/hdr_image.hpp"

namespace glint {

inline constexpr double kPi = std::numbers::pi;
inline constexpr double kTwoPi = 2.0 * std::numbers::pi;

// Polar angle of the centre of row j and azimuth of the centre of column i.
inline double row_theta(int j, int height) { return kPi * (j + 0.5) / height; }
inline double column_phi(int i, int width) { return kTwoPi * (i + 0.5) / width - kPi; }

glm::dvec3 direction_from_angles(double theta, double phi);
glm::dvec3 texel_direction(int i, int j, int width, int height);

// Continuous texel coordinates (x in [0, W), y in [0, H)) of a unit direction:
// x = u * W, y = v * H. A texel's centre is at (i + 0.5, j + 0.5).
struct TexelCoord {
    double x = 0, y = 0;
};
TexelCoord direction_to_texel(const glm::dvec3& d, int width, int height);

// Exact solid angle of one texel in row j (all texels in a row share it).
double row_solid_angle(int j, int width, int height);
std::vector<double> row_solid_angles(int width, int height);

// Bilinear lookup at a direction, the way a renderer samples a map: wraps in
// azimuth, clamps in polar angle (the first and last rows hold up to the poles).
Rgb sample_bilinear(const HdrImage& image, const glm::dvec3& d);

// The lobe lookup of a map whose lobe is narrower than its texel spacing (half of it, or a whole
// one where bilinear grids fail; docs/convolution.md, "The lobe lookup"): the conventions' reflection sum E^n(d) itself, taken over the texels of
// `image` that can matter,
//   sum_k (d.w_k / cmax)^n dOmega_k L_k  /  sum_k (d.w_k / cmax)^n dOmega_k,
// where `image` holds the environment's own texels L_k. Between texel centres such a map is a
// step no grid resolves for bilinear lookups; this lookup follows it. Only texels whose weight
// is within exp(-kLobeLookupSpan) of the texel the direction falls in are visited (a few
// neighbours for n = 1e6 on 1024x512 off the poles; at a pole a whole row or more, about 1,000
// texels there, tens of thousands for n = 4.3e5 on 4096x2048), found from the haversine of the
// angle between the direction and each texel centre, so no candidate is missed across the seam
// or a pole. `shininess` must be finite and > 0. In double; the renderer's GLSL
// (shaders/render_lookup.glsl, equirect_lobe) is the same in float.
// A smaller `span` leaves out texels up to exp(-span) of it (an estimate that needs no more:
// spot_lookup_worst takes 20).
inline constexpr double kLobeLookupSpan = 36.0;  // e^-36 = 2.3e-16: below double rounding
Rgb sample_lobe(const HdrImage& image, const glm::dvec3& d, double shininess, double span = kLobeLookupSpan);

// How a renderer reads a map between its texel centres (report.json's "lookup").
enum class MapLookup { Bilinear, Lobe };
const char* to_string(MapLookup lookup);
// "bilinear" or "lobe" (report.json, maps.json); nothing for any other name.
std::optional<MapLookup> map_lookup_from_string(const std::string& name);
// `shininess`: the lobe's, used by the lobe lookup only.
inline Rgb sample_map(const HdrImage& image, const glm::dvec3& d, MapLookup lookup, double shininess) {
    return lookup == MapLookup::Lobe ? sample_lobe(image, d, shininess) : sample_bilinear(image, d);
}

// A lobe-lookup map (sample_lobe) read at the texel centres of a width x height grid: its values
// where a reference of that grid holds the exact sums (engine Method::Lobe). threads 0: all cores.
HdrImage resample_lobe(const HdrImage& image, int width, int height, double shininess, int threads = 1);

// Resample a map to another size by bilinear lookup at the new texel centres.
HdrImage resample_bilinear(const HdrImage& image, int width, int height);

}  // namespace glint
