// Live maps (docs/render.md, "Live maps"): coarse maps at once, the final ones made by the GPU
// engine on a worker thread only in the slices the render loop grants; they agree with the CPU
// engine's, and the renderer switches to them.
#include <gtest/gtest.h>

#include <cmath>

#include "appliance/convolution/convolution.hpp"
#include "appliance/render/live_maps.hpp"
#include "appliance/render/maps.hpp"
#include "appliance/render/material.hpp"
#include "appliance/render/mesh.hpp"
#include "appliance/render/renderer.hpp"
#include "gpu_fixture.hpp"
#include "render_worlds.hpp"

namespace glint {
namespace {

class RenderLive : public test::GpuTest {};

double relative_rms(const HdrImage& a, const HdrImage& b) {
    double num = 0, den = 0;
    for (std::size_t k = 0; k < a.data().size(); ++k) {
        num += double(a.data()[k] - b.data()[k]) * double(a.data()[k] - b.data()[k]);
        den += double(b.data()[k]) * double(b.data()[k]);
    }
    return std::sqrt(num / den);
}

TEST_F(RenderLive, FinalMapsComeOnlyInGrantedSlicesAndMatchTheCpuEngine) {
    const HdrImage env = test::small_blender_world("courtyard");
    const std::vector<render::Material> materials = {render::parse_material("matte"), render::parse_material("glossy:20")};

    const render::ShadingMaps coarse = render::coarse_maps(env, materials, 2);
    ASSERT_TRUE(coarse.irradiance);
    EXPECT_EQ(coarse.irradiance->width(), 32);
    ASSERT_NE(coarse.reflection_for(materials[1]), nullptr);
    EXPECT_EQ(coarse.reflection_for(materials[1])->image.width(), 32);

    render::LiveMaps live(context(), env, materials, 40.0);
    // A frame that used its whole budget grants nothing.
    EXPECT_EQ(live.after_frame(40.0), 0.0);
    EXPECT_EQ(live.after_frame(55.0), 0.0);
    // Frames of 10 ms grant 30 ms each until the job is done.
    int frames = 0;
    while (!live.done() && frames < 5000) {
        EXPECT_NEAR(live.after_frame(10.0), 30.0, 1e-9);
        ++frames;
    }
    ASSERT_TRUE(live.done()) << "not done after " << frames << " slices";
    EXPECT_EQ(live.after_frame(10.0), 0.0);  // nothing left to grant
    EXPECT_GT(frames, 1);                    // it took several frames' slices
    EXPECT_GT(live.tiles().tiles, 0);
    std::optional<render::ShadingMaps> final_maps = live.take();
    ASSERT_TRUE(final_maps);
    EXPECT_FALSE(live.take());  // once

    convolution::Options cpu;
    cpu.tolerance = 0.01;
    cpu.threads = 2;
    const render::ShadingMaps reference = render::convolve_maps(env, materials, cpu);
    ASSERT_TRUE(final_maps->irradiance && final_maps->reflection_for(materials[1]));
    EXPECT_EQ(final_maps->irradiance->width(), reference.irradiance->width());
    EXPECT_LT(relative_rms(*final_maps->irradiance, *reference.irradiance), 0.005);
    EXPECT_LT(relative_rms(final_maps->reflection_for(materials[1])->image, reference.reflection_for(materials[1])->image),
              0.005);
    std::printf("[          ] live maps: %d slices of 30 ms, %lld tiles, %.0f ms GPU, %.2f s\n", frames,
                live.tiles().tiles, live.tiles().gpu_ms, live.seconds());

    // The renderer switches: after replace_maps its radiance is that of a renderer made with the
    // final maps, and differs from the coarse one's.
    const render::Mesh sphere = render::make_uv_sphere(24, 48);
    const render::Material mixed = render::parse_material("kd=0.5;ks=0.5;n=20");
    render::Renderer switched(sphere, mixed, coarse, 64, 48);
    switched.draw_scene();
    const std::vector<float> before = switched.read_aovs().radiance;
    switched.replace_maps(*final_maps);
    switched.draw_scene();
    const std::vector<float> after = switched.read_aovs().radiance;
    render::Renderer direct(sphere, mixed, *final_maps, 64, 48);
    direct.draw_scene();
    const std::vector<float> want = direct.read_aovs().radiance;
    double moved = 0, off = 0;
    for (std::size_t k = 0; k < want.size(); ++k) {
        moved = std::max(moved, double(std::abs(after[k] - before[k])));
        off = std::max(off, double(std::abs(after[k] - want[k])));
    }
    EXPECT_EQ(off, 0.0);
    EXPECT_GT(moved, 1e-3);
}

// The kiosk's worker lives for the whole run: made once (context and programs), then one job per
// visitor's room. A room started while another is being made replaces it.
TEST_F(RenderLive, OneWorkerMakesEachRoomsMapsInTurnAndANewRoomReplacesARunningJob) {
    const HdrImage courtyard = test::small_blender_world("courtyard");
    const HdrImage studio = test::small_blender_world("studio");
    const std::vector<render::Material> materials = {render::parse_material("matte"), render::parse_material("glossy:20")};
    render::LiveMaps live(context(), 40.0);
    EXPECT_TRUE(live.ready());
    EXPECT_FALSE(live.done());                 // no job yet
    EXPECT_EQ(live.after_frame(10.0), 0.0);    // nothing to grant to
    EXPECT_FALSE(live.take());
    live.finish();                             // returns: nothing to finish

    const auto run_to_end = [&] {
        int frames = 0;
        while (!live.done() && frames < 5000) {
            live.after_frame(10.0);
            ++frames;
        }
        EXPECT_TRUE(live.done());
        return frames;
    };
    live.start(studio, materials);
    run_to_end();
    const std::optional<render::ShadingMaps> first = live.take();
    ASSERT_TRUE(first && first->irradiance);
    EXPECT_GT(live.tiles().tiles, 0);

    // The next room: a few slices, then a newer room replaces it before it is done.
    live.start(courtyard, materials);
    EXPECT_FALSE(live.done());
    live.after_frame(35.0);
    live.start(studio, materials);
    run_to_end();
    const std::optional<render::ShadingMaps> again = live.take();
    ASSERT_TRUE(again && again->irradiance);
    EXPECT_FALSE(live.take());
    // The same room gives the same maps on the same worker (the cancelled job left nothing behind).
    EXPECT_LT(relative_rms(*again->irradiance, *first->irradiance), 1e-6);
    EXPECT_LT(relative_rms(again->reflection_for(materials[1])->image, first->reflection_for(materials[1])->image), 1e-6);

    // And another room's maps are that room's.
    live.start(courtyard, materials);
    live.finish();
    const std::optional<render::ShadingMaps> third = live.take();
    ASSERT_TRUE(third && third->irradiance);
    convolution::Options cpu;
    cpu.tolerance = 0.01;
    cpu.threads = 2;
    const render::ShadingMaps reference = render::convolve_maps(courtyard, materials, cpu);
    EXPECT_LT(relative_rms(*third->irradiance, *reference.irradiance), 0.005);
    EXPECT_GT(relative_rms(*third->irradiance, *first->irradiance), 0.05);  // not the studio's
}

}  // namespace
}  // namespace glint
