// The dominant lights of an environment map (appliance/render/dominant_lights.hpp) on generated
// maps: a uniform disc of known direction, solid angle and radiance drawn into a dim background
// with each texel's exact coverage (supersampled uniformly in solid angle), at the poles, across
// the seam and in the open. The found light must point at the disc within a texel and carry its
// solid angle and energy within 2 %.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <ostream>
#include <string>

#include "appliance/core/equirect.hpp"
#include "appliance/core/errors.hpp"
#include "appliance/render/dominant_lights.hpp"

namespace glint {
namespace {

using render::DominantLightOptions;
using render::find_dominant_lights;

struct Disc {
    glm::dvec3 direction;
    double radius;  // angular, radians
    glm::dvec3 radiance;
    double solid_angle() const { return kTwoPi * (1.0 - std::cos(radius)); }
};

// Background `bg` everywhere, each disc drawn over it with its coverage of the texel: 8x32
// sub-samples per texel, uniform in cos(theta) and phi, i.e. in solid angle.
HdrImage map_with(int w, int h, const std::vector<Disc>& discs, glm::dvec3 bg = glm::dvec3(0.5, 0.6, 0.7)) {
    HdrImage img(w, h);
    // 32 sub-rows: a disc centred on a pole cuts every texel of a row at the same place, so a
    // coarse sub-grid would be off by the same fraction all around (1.5 % with 8).
    constexpr int kSub = 8, kSubRows = 32;
    for (int j = 0; j < h; ++j) {
        const double c0 = std::cos(kPi * j / h), c1 = std::cos(kPi * (j + 1) / h);
        for (int i = 0; i < w; ++i) {
            glm::dvec3 value = bg;
            for (const Disc& d : discs) {
                const double cos_r = std::cos(d.radius);
                // Quick reject: the texel's centre farther than the radius plus the texel's size.
                const double span = kPi / h + kTwoPi / w;
                if (glm::dot(texel_direction(i, j, w, h), d.direction) < std::cos(std::min(kPi, d.radius + 2 * span)))
                    continue;
                int inside = 0;
                for (int a = 0; a < kSubRows; ++a)
                    for (int b = 0; b < kSub; ++b) {
                        const double ct = c0 + (c1 - c0) * (a + 0.5) / kSubRows;
                        const double phi = kTwoPi * (i + (b + 0.5) / kSub) / w - kPi;
                        const double st = std::sqrt(std::max(0.0, 1 - ct * ct));
                        const glm::dvec3 dir(st * std::sin(phi), ct, -st * std::cos(phi));
                        if (glm::dot(dir, d.direction) >= cos_r) ++inside;
                    }
                const double cov = double(inside) / (kSub * kSubRows);
                value = cov * d.radiance + (1 - cov) * value;
            }
            img.set(i, j, {float(value.x), float(value.y), float(value.z)});
        }
    }
    return img;
}

double angle_between(const glm::dvec3& a, const glm::dvec3& b) {
    return std::atan2(glm::length(glm::cross(a, b)), glm::dot(a, b));
}

glm::dvec3 unit(double x, double y, double z) { return glm::normalize(glm::dvec3(x, y, z)); }

struct Case {
    std::string name;
    glm::dvec3 direction;
};
// CTest's listing prints the case by name, not as raw bytes.
[[maybe_unused]] void PrintTo(const Case& c, std::ostream* os) { *os << c.name; }

class DominantLightsDisc : public ::testing::TestWithParam<Case> {};

TEST_P(DominantLightsDisc, FindsTheDiscsDirectionSolidAngleAndEnergy) {
    const int w = 512, h = 256;
    const Disc disc{GetParam().direction, 4.0 * kPi / 180.0, {2000.0, 1800.0, 1500.0}};
    const HdrImage map = map_with(w, h, {disc});
    const auto found = find_dominant_lights(map);
    ASSERT_EQ(found.lights.size(), 1u);
    const auto& l = found.lights[0];
    const double texel = kPi / h;
    std::printf("%-22s direction off %.3f texels, solid angle x %.4f, energy x %.4f\n", GetParam().name.c_str(),
                angle_between(l.direction, disc.direction) / texel, l.solid_angle / disc.solid_angle(),
                l.energy.y / (disc.radiance.y * disc.solid_angle()));
    EXPECT_LT(angle_between(l.direction, disc.direction), texel) << GetParam().name;
    EXPECT_NEAR(l.solid_angle / disc.solid_angle(), 1.0, 0.02) << GetParam().name;
    const glm::dvec3 energy = disc.radiance * disc.solid_angle();
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(l.energy[c] / energy[c], 1.0, 0.02) << GetParam().name << " channel " << c;
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(l.radiance[c] / disc.radiance[c], 1.0, 0.03) << GetParam().name;
    EXPECT_NEAR(l.angular_radius(), disc.radius, 0.01 * disc.radius);
}

INSTANTIATE_TEST_SUITE_P(
    Places, DominantLightsDisc,
    ::testing::Values(Case{"zenith", {0, 1, 0}}, Case{"nadir", {0, -1, 0}},
                      Case{"near_zenith_off_axis", unit(0.03, 1, 0.02)},  // covers the pole off-centre
                      Case{"seam_equator", {0, 0, 1}},                     // u = 0: columns W-1 and 0
                      Case{"seam_raised", unit(0.0, 0.6, 0.8)},
                      Case{"open", unit(0.4, 0.5, -0.77)}, Case{"open_low", unit(-0.8, -0.3, 0.2)}),
    [](const auto& p) { return p.param.name; });

TEST(DominantLights, SmallDiscStillGetsItsSolidAngle) {
    // 1.5 degrees on a 256x128 map (1.4-degree texels): about 3 texels across.
    const Disc disc{unit(0.2, 0.7, -0.3), 1.5 * kPi / 180.0, {5e4, 5e4, 5e4}};
    const auto found = find_dominant_lights(map_with(256, 128, {disc}));
    ASSERT_EQ(found.lights.size(), 1u);
    EXPECT_LT(angle_between(found.lights[0].direction, disc.direction), kPi / 128);
    EXPECT_NEAR(found.lights[0].solid_angle / disc.solid_angle(), 1.0, 0.05);
    EXPECT_NEAR(found.lights[0].energy.x / (disc.radiance.x * disc.solid_angle()), 1.0, 0.02);
}

TEST(DominantLights, RanksByEnergyKeepsAtMostMaxAndDropsSpecks) {
    const std::vector<Disc> discs = {
        {unit(0, 1, 0.2), 3.0 * kPi / 180, {500, 500, 500}},     // middle
        {unit(1, 0.3, 0), 6.0 * kPi / 180, {500, 500, 500}},     // largest (4x the solid angle)
        {unit(-1, 0.2, -1), 2.0 * kPi / 180, {300, 300, 300}},   // smallest of the three
        {unit(0, -0.3, -1), 0.3 * kPi / 180, {500, 500, 500}},   // a speck: < 1 % of the map's energy
    };
    const HdrImage map = map_with(256, 128, discs);
    DominantLightOptions o;
    const auto all = find_dominant_lights(map, o);
    ASSERT_EQ(all.lights.size(), 3u);
    EXPECT_LT(angle_between(all.lights[0].direction, discs[1].direction), kPi / 128);
    EXPECT_LT(angle_between(all.lights[1].direction, discs[0].direction), kPi / 128);
    EXPECT_LT(angle_between(all.lights[2].direction, discs[2].direction), kPi / 128);
    o.max_lights = 2;
    EXPECT_EQ(find_dominant_lights(map, o).lights.size(), 2u);
    o.max_lights = 0;
    EXPECT_TRUE(find_dominant_lights(map, o).lights.empty());
}

TEST(DominantLights, FacingKeepsLightsBelowThePlaneAmbient) {
    const std::vector<Disc> discs = {{unit(0.2, -0.8, 0.1), 5.0 * kPi / 180, {900, 900, 900}},  // below, brighter
                                     {unit(-0.3, 0.6, 0.2), 3.0 * kPi / 180, {900, 900, 900}}};
    const HdrImage map = map_with(128, 64, discs);
    DominantLightOptions o;
    EXPECT_EQ(find_dominant_lights(map, o).lights.size(), 2u);
    o.facing = glm::dvec3(0, 1, 0);
    const auto up = find_dominant_lights(map, o);
    ASSERT_EQ(up.lights.size(), 1u);
    EXPECT_LT(angle_between(up.lights[0].direction, discs[1].direction), kPi / 64);
    // The one below stays in the ambient part at full radiance.
    const TexelCoord t = direction_to_texel(discs[0].direction, 128, 64);
    EXPECT_GT(up.ambient.at(int(t.x), int(t.y)).g, 800.0f);
    o.max_lights = 1;  // the one above still gets the only place
    EXPECT_EQ(find_dominant_lights(map, o).lights.size(), 1u);
}

TEST(DominantLights, LightsPlusAmbientAreTheWholeMap) {
    const std::vector<Disc> discs = {{unit(0.3, 1, 0), 5.0 * kPi / 180, {800, 700, 600}},
                                     {unit(0, 0, 1), 3.0 * kPi / 180, {900, 900, 1000}}};
    const HdrImage map = map_with(128, 64, discs);
    const auto found = find_dominant_lights(map);
    ASSERT_EQ(found.lights.size(), 2u);
    const auto domega = row_solid_angles(128, 64);
    glm::dvec3 whole(0.0), ambient(0.0), lights(0.0);
    for (int j = 0; j < 64; ++j)
        for (int i = 0; i < 128; ++i) {
            const Rgb a = map.at(i, j), b = found.ambient.at(i, j);
            whole += glm::dvec3(a.r, a.g, a.b) * domega[std::size_t(j)];
            ambient += glm::dvec3(b.r, b.g, b.b) * domega[std::size_t(j)];
        }
    for (const auto& l : found.lights) lights += l.energy;
    for (int c = 0; c < 3; ++c) EXPECT_NEAR((ambient[c] + lights[c]) / whole[c], 1.0, 1e-9);
    // The ambient part is the dim background: nothing in it is near the lights' radiance.
    float brightest = 0;
    for (float v : found.ambient.data()) brightest = std::max(brightest, v);
    EXPECT_LT(brightest, 3.0f * float(found.mean_luminance));
}

TEST(DominantLights, UniformMapHasNoLights) {
    const auto found = find_dominant_lights(map_with(64, 32, {}));
    EXPECT_TRUE(found.lights.empty());
    EXPECT_NEAR(found.mean_luminance, 0.2126 * 0.5 + 0.7152 * 0.6 + 0.0722 * 0.7, 1e-6);
}

TEST(DominantLights, IrradianceOfAConstantMapIsPiTimesIt) {
    const HdrImage map = map_with(256, 128, {}, glm::dvec3(2.0));
    // Texel centres, not the exact integral: within 0.1 % at this size.
    EXPECT_NEAR(render::irradiance_on(map, {0, 1, 0}).x / (kPi * 2.0), 1.0, 1e-3);
    EXPECT_NEAR(render::irradiance_on(map, unit(1, 1, 0)).y / (kPi * 2.0), 1.0, 1e-3);
}

TEST(DominantLights, BadInputIsAnInputError) {
    EXPECT_THROW(find_dominant_lights(HdrImage()), InputError);
    DominantLightOptions o;
    o.grow_ratio = 20;  // above the seed ratio
    EXPECT_THROW(find_dominant_lights(map_with(8, 4, {}), o), InputError);
}

}  // namespace
}  // namespace glint
