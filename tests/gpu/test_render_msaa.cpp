// MSAA of the renderer (docs/render.md, "MSAA"): with 4 samples a pixel the object's silhouette
// is antialiased (pixels it partly covers have a fractional coverage and a mixed colour), with
// one it is not, and the AOVs stay exact (identical with and without MSAA).
#include <gtest/gtest.h>

#include <cmath>

#include "appliance/core/errors.hpp"
#include "appliance/gl/gl_targets.hpp"
#include "appliance/render/maps.hpp"
#include "appliance/render/material.hpp"
#include "appliance/render/mesh.hpp"
#include "appliance/render/renderer.hpp"
#include "gpu_fixture.hpp"

namespace glint {
namespace {

class RenderMsaa : public test::GpuTest {};

constexpr int kW = 96, kH = 64;

// A constant irradiance of 1: a matte object has radiance 1 everywhere, so a resolved pixel's
// RGB is exactly its coverage.
render::ShadingMaps uniform_maps() {
    render::ShadingMaps maps;
    HdrImage e(16, 8);
    for (std::size_t k = 0; k < 3 * e.texel_count(); ++k) e.data()[k] = 1.0f;
    maps.irradiance = e;
    return maps;
}

struct Coverage {
    int partial = 0, full = 0;
    double worst_rgb_vs_alpha = 0;  // max |R - A| over the partial pixels
    int example = -1;               // a partly covered pixel
};

Coverage coverage(const std::vector<float>& rgba) {
    Coverage c;
    for (std::size_t k = 0; 4 * k < rgba.size(); ++k) {
        const float a = rgba[4 * k + 3];
        if (a >= 1.0f) ++c.full;
        if (a > 0.0f && a < 1.0f) {
            ++c.partial;
            c.worst_rgb_vs_alpha = std::max(c.worst_rgb_vs_alpha, double(std::abs(rgba[4 * k] - a)));
            if (c.example < 0) c.example = int(k);
        }
    }
    return c;
}

TEST_F(RenderMsaa, FourSamplesGiveFractionalCoverageOnTheSilhouetteOneDoesNot) {
    const render::Material matte = render::parse_material("matte");
    const render::ShadingMaps maps = uniform_maps();
    const render::Mesh sphere = render::make_uv_sphere(24, 48);

    render::Renderer one(sphere, matte, maps, kW, kH, render::Camera{}, 1);
    one.set_background_black();
    one.draw_scene();
    const Coverage c1 = coverage(one.read_frame_radiance());
    EXPECT_EQ(c1.partial, 0);
    EXPECT_GT(c1.full, 1000);

    render::Renderer four(sphere, matte, maps, kW, kH, render::Camera{}, 4);
    EXPECT_EQ(four.msaa(), 4);
    four.set_background_black();
    four.draw_scene();
    const std::vector<float> frame = four.read_frame_radiance();
    const Coverage c4 = coverage(frame);
    // The sphere's outline is about 2 pi 25 = 160 pixels long at this size.
    EXPECT_GT(c4.partial, 80) << "too few antialiased pixels on the silhouette";
    EXPECT_LT(c4.partial, 400);
    // The resolve is the mean of the samples: radiance 1 premultiplied by the coverage.
    EXPECT_LT(c4.worst_rgb_vs_alpha, 1e-3);
    // Interior pixels fully covered in both.
    EXPECT_NEAR(double(c4.full), double(c1.full), 0.2 * c1.full);

    // The composite mixes the object and the background at a partly covered pixel: over black,
    // its display value lies strictly between black and the object's interior value.
    gl::RenderTargets frame_target(kW, kH, 1);
    frame_target.bind();
    glViewport(0, 0, kW, kH);
    four.composite();
    const std::vector<float> shown = frame_target.read(0);  // bottom row first, as GL reads
    ASSERT_GE(c4.example, 0);
    const int ex = c4.example % kW, ey = kH - 1 - c4.example / kW;  // read_frame_radiance is top first
    const float partial = shown[4 * std::size_t(ey * kW + ex)];
    const float centre = shown[4 * std::size_t((kH / 2) * kW + kW / 2)];
    EXPECT_GT(partial, 0.0f);
    EXPECT_LT(partial, centre);
}

// The maps of a glossy material: irradiance 1 and a reflection map ramping across the texels,
// with `sun` (if > 0) at texel (5, 3).
render::ShadingMaps glossy_maps(const render::Material& glossy, float sun = 0) {
    render::ShadingMaps maps = uniform_maps();
    HdrImage refl(16, 8);
    for (int j = 0; j < refl.height(); ++j)
        for (int i = 0; i < refl.width(); ++i)
            for (int c = 0; c < 3; ++c) refl.row(j)[3 * i + c] = float(1 + i + 3 * j + c);
    if (sun > 0) refl.row(3)[3 * 5] = sun;
    maps.set_reflection(glossy, refl);
    return maps;
}

TEST_F(RenderMsaa, AovsAreTheSameWithAndWithoutMsaa) {
    const render::Material glossy = render::parse_material("kd=0.5;ks=0.5;n=40");
    const render::ShadingMaps maps = glossy_maps(glossy);
    const render::Mesh sphere = render::make_uv_sphere(24, 48);
    render::Renderer one(sphere, glossy, maps, kW, kH, render::Camera{}, 1);
    render::Renderer four(sphere, glossy, maps, kW, kH, render::Camera{}, 4);
    one.draw_scene();
    four.draw_scene();
    const render::Aovs a = one.read_aovs(), b = four.read_aovs();
    ASSERT_EQ(a.radiance.size(), b.radiance.size());
    double worst = 0;
    for (std::size_t k = 0; k < a.radiance.size(); ++k) {
        worst = std::max(worst, double(std::abs(a.radiance[k] - b.radiance[k])));
        worst = std::max(worst, double(std::abs(a.normal[k] - b.normal[k])));
        worst = std::max(worst, double(std::abs(a.reflect[k] - b.reflect[k])));
    }
    EXPECT_EQ(worst, 0.0);
    for (std::size_t k = 3; k < b.radiance.size(); k += 4) EXPECT_TRUE(b.radiance[k] == 0.0f || b.radiance[k] == 1.0f);
}

// Half-float frame targets (RGBA16F, the plan for a tile-based GPU; docs/render.md, "Frame
// targets"), 4x MSAA: the frame's radiance within half's 1e-3 of the float frame's, the AOVs
// identical (they have RGBA32F targets of their own), and a mirror of a sun far past half's range
// at 65504, not infinite: its resolved pixels, the meter and the displayed frame stay finite.
// (llvmpipe saturates a float too large for half by itself, so this passes here without the
// shaders' cap too; GPUs that round it to infinity need the cap.)
TEST_F(RenderMsaa, HalfFloatFramesMatchFloatAndKeepTheAovsExact) {
    const render::Material glossy = render::parse_material("kd=0.5;ks=0.5;n=40");
    const render::ShadingMaps maps = glossy_maps(glossy, 1e6f);  // a sun beyond half's 65504
    const render::Mesh sphere = render::make_uv_sphere(24, 48);
    render::Renderer full(sphere, glossy, maps, kW, kH, render::Camera{}, 4, render::FrameTargets::Float);
    render::Renderer half(sphere, glossy, maps, kW, kH, render::Camera{}, 4, render::FrameTargets::Half);
    EXPECT_STREQ(full.frame_format(), "RGBA32F");
    EXPECT_STREQ(half.frame_format(), "RGBA16F");
    EXPECT_STREQ(render::Renderer(sphere, glossy, maps, 8, 8, render::Camera{}, 4).frame_format(), "RGBA32F");  // auto, llvmpipe
    full.draw_scene();
    half.draw_scene();
    const std::vector<float> a = full.read_frame_radiance(), b = half.read_frame_radiance();
    ASSERT_EQ(a.size(), b.size());
    double worst = 0;
    int capped = 0;
    for (std::size_t k = 0; k < a.size(); ++k) {
        ASSERT_TRUE(std::isfinite(b[k])) << "texel " << k / 4;
        if (a[k] > 65504.0f) {
            ++capped;
            EXPECT_LE(b[k], 65504.0f);
            continue;
        }
        if (a[k] > 1e3f) continue;  // a pixel the sun's cap reached through the resolve
        worst = std::max(worst, double(std::abs(a[k] - b[k])) / std::max(1.0, double(std::abs(a[k]))));
    }
    EXPECT_GT(capped, 0) << "the sun was not reflected: the test does not reach the cap";
    EXPECT_LT(worst, 2e-3);
    const render::Aovs fa = full.read_aovs(), ha = half.read_aovs();
    EXPECT_EQ(fa.radiance, ha.radiance);
    EXPECT_EQ(fa.normal, ha.normal);
    EXPECT_EQ(fa.reflect, ha.reflect);
    const render::ToneMap& tone = half.meter();
    EXPECT_TRUE(std::isfinite(tone.log_average)) << tone.log_average;
    gl::RenderTargets shown(kW, kH, 1);
    shown.bind();
    glViewport(0, 0, kW, kH);
    half.composite();
    for (const float v : shown.read(0)) ASSERT_TRUE(std::isfinite(v));
}

TEST_F(RenderMsaa, OtherSampleCountsAreRefusedNamingTheFlag) {
    try {
        render::Renderer r(render::make_uv_sphere(8, 16), render::parse_material("matte"), uniform_maps(), 8, 8,
                           render::Camera{}, 2);
        FAIL() << "msaa 2 accepted";
    } catch (const InputError& e) {
        EXPECT_NE(std::string(e.what()).find("--msaa"), std::string::npos) << e.what();
    }
}

}  // namespace
}  // namespace glint
