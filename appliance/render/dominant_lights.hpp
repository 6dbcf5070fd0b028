// The few lights of an environment map that cast the shadows worth drawing (docs/render.md,
// "Table, phantom geometry and shadows"), and the rest of the map as ambient light.
//
// A light is a connected region of bright texels: seeded by texels whose luminance exceeds
// `seed_ratio` times the map's mean luminance (the solid-angle weighted mean of
// docs/conventions.md), brightest first, grown over neighbours above `grow_ratio` times it and
// above `core_fraction` of the seed's luminance, then by one ring of neighbours above `grow_ratio`
// (so the partly covered texels at a light's rim keep their energy). Neighbours are the 8 around a
// texel, with columns wrapping across the seam and the first (last) row joined across the pole to
// the texel half a turn away. The regions are ranked by energy (luminance times solid angle) and
// the largest `max_lights` kept (optionally only those above a plane and no wider than a
// radius); the rest of the map, with
// those texels set to 0, is the ambient part, so lights + ambient sum to the map exactly.
//
// Each light is summarised as a uniform disc: its energy E = sum L_k dOmega_k (RGB), its direction
// the luminance-weighted mean of the texels' directions (each texel's exact mean direction over
// its own area), and its solid angle the smaller of two estimates:
//  - the spread: for a uniform disc of angular radius a, the mean of cos(angle to the centre) over
//    the disc is (1 + cos a) / 2, so with m the luminance-weighted mean unit vector,
//    Omega = 2 pi (1 - cos a) = 4 pi (1 - |m|); a region that is not a disc gets the disc of the
//    same spread. Too wide by the rim texels' footprint (43 % for a disc 2 texels in radius).
//  - energy over the peak: sum L_k dOmega_k / max L_k (luminance), exact for a uniform light with
//    at least one fully covered texel; smaller than the spread for a light with a bright core.
// Radiance = E / Omega. A light smaller than a texel gets about a texel's solid angle.
#pragma once

#include <optional>
#include <vector>

#include <glm/glm.hpp>

#include "appliance/core/hdr_image.hpp"

namespace glint::render {

struct DominantLight {
    glm::dvec3 direction{0.0, 1.0, 0.0};  // unit, world frame (+Y up)
    double solid_angle = 0;               // sr, of the equivalent uniform disc
    glm::dvec3 radiance{0.0};             // RGB, energy / solid_angle
    glm::dvec3 energy{0.0};               // RGB, sum of L dOmega over the region
    int texels = 0;                       // texels of the region
    // With DominantLightOptions::facing: what the light gives a surface with that normal, from its
    // own texels (sum L_k max(0, n . w_k) dOmega_k: exact also for a light across the horizon), and
    // the direction that irradiance comes from on average (the same weights on the directions).
    glm::dvec3 facing_irradiance{0.0};
    glm::dvec3 facing_direction{0.0, 1.0, 0.0};
    double angular_radius() const;        // a, with solid_angle = 2 pi (1 - cos a)
};

struct DominantLightOptions {
    int max_lights = 4;
    double seed_ratio = 10.0;  // a seed texel's luminance over the map's mean luminance
    double grow_ratio = 3.0;   // a region grows over texels above this times the mean
    // ... and above this fraction of its seed's (its peak's) luminance, plus one ring of texels
    // above grow_ratio: a sun keeps its sharp core and its rim; the glow around it stays ambient
    // or becomes a light of its own (0: the whole connected region is one light).
    double core_fraction = 0.1;
    // Regions with less than this share of the map's energy (luminance) stay ambient: specks
    // that would cost a shadow each and darken nothing visibly.
    double min_energy_share = 0.01;
    // When set, a region whose disc lies wholly below the plane with this unit normal is not a
    // light (it cannot light that surface) and stays ambient; the next one takes its place.
    std::optional<glm::dvec3> facing;
    // Regions whose disc is wider than this (angular radius, radians) are not lights and stay ambient.
    double max_angular_radius = 3.15;
};

struct LightDecomposition {
    std::vector<DominantLight> lights;  // largest energy first
    HdrImage ambient;                   // the map with the lights' texels set to 0
    double mean_luminance = 0;          // solid-angle weighted, over the whole map
};

// Throws InputError on an empty map or bad options.
LightDecomposition find_dominant_lights(const HdrImage& environment, const DominantLightOptions& options = {});

// The irradiance that the map (RGB radiance) gives a surface with the unit normal `normal`:
// sum_k L_k max(0, normal . w_k) dOmega_k over the texel centres w_k (not divided by pi).
glm::dvec3 irradiance_on(const HdrImage& environment, const glm::dvec3& normal);

}  // namespace glint::render
