// Baked ambient occlusion in the renderer (docs/render.md, "Ambient occlusion"): the radiance AOV
// is kd E_d(N) ao + ks E_s^n(R) with ao read from the model's .ao file, interpolated over the
// triangles; --no-ao gives ao = 1; the specular term never sees ao.
#include <gtest/gtest.h>

#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>

#include "appliance/core/equirect.hpp"
#include "appliance/core/errors.hpp"
#include "appliance/render/ao_file.hpp"
#include "appliance/render/maps.hpp"
#include "appliance/render/material.hpp"
#include "appliance/render/mesh.hpp"
#include "appliance/render/renderer.hpp"
#include "gpu_fixture.hpp"
#include "render_worlds.hpp"

namespace glint {
namespace {

namespace fs = std::filesystem;

class RenderAo : public test::GpuTest {};

// An ao that is linear in the position, so that the triangles' interpolation reproduces it at
// every pixel: on the unit sphere the position is the normal (to the chords' sag, 1e-4).
double ao_of(const glm::dvec3& p) { return 0.2 + 0.3 * (1.0 + p.y); }

// The sphere written as an OBJ file, as a user's model would be.
fs::path write_sphere_obj(const fs::path& dir) {
    const render::Mesh s = render::make_uv_sphere(48, 96);
    const fs::path path = dir / "sphere.obj";
    std::ofstream out(path);
    out.precision(9);
    for (std::size_t i = 0; i < s.positions.size(); ++i) {
        out << "v " << s.positions[i].x << " " << s.positions[i].y << " " << s.positions[i].z << "\n";
        out << "vn " << s.normals[i].x << " " << s.normals[i].y << " " << s.normals[i].z << "\n";
    }
    for (std::size_t t = 0; t < s.indices.size(); t += 3)
        out << "f " << s.indices[t] + 1 << "//" << s.indices[t] + 1 << " " << s.indices[t + 1] + 1 << "//"
            << s.indices[t + 1] + 1 << " " << s.indices[t + 2] + 1 << "//" << s.indices[t + 2] + 1 << "\n";
    return path;
}

struct Error {
    double rms = 0, worst = 0;
    long long pixels = 0;
};

// The radiance AOV against kd E_d(N) ao(N) + ks E_s(R), maps looked up on the CPU at the AOVs'
// own directions (as test_render.cpp does, with ao added).
Error against(const render::Aovs& a, const render::Material& m, const render::ShadingMaps& maps, bool with_ao) {
    double num = 0, den = 0, worst = 0;
    Error e;
    for (std::size_t k = 0; k < std::size_t(a.width) * std::size_t(a.height); ++k) {
        if (a.radiance[4 * k + 3] == 0) continue;
        const glm::dvec3 n(a.normal[4 * k], a.normal[4 * k + 1], a.normal[4 * k + 2]);
        const glm::dvec3 r(a.reflect[4 * k], a.reflect[4 * k + 1], a.reflect[4 * k + 2]);
        const Rgb d = sample_bilinear(*maps.irradiance, n);
        const Rgb s = sample_bilinear(*maps.reflection(), r);
        const double ao = with_ao ? ao_of(n) : 1.0;
        const glm::dvec3 want = m.kd * glm::dvec3(d.r, d.g, d.b) * ao + m.ks * glm::dvec3(s.r, s.g, s.b);
        for (int c = 0; c < 3; ++c) {
            const double diff = a.radiance[4 * k + std::size_t(c)] - want[c];
            num += diff * diff;
            den += want[c] * want[c];
            worst = std::max(worst, std::abs(diff) / std::max(1e-6, want[c]));
        }
        ++e.pixels;
    }
    e.rms = std::sqrt(num / den);
    e.worst = worst;
    return e;
}

TEST_F(RenderAo, RadianceIsDiffuseTimesAoFromTheFilePlusSpecular) {
    const fs::path dir = fs::temp_directory_path() / ("glint_test_render_ao_" + std::to_string(::getpid()));
    fs::remove_all(dir);
    fs::create_directories(dir);
    const fs::path model = write_sphere_obj(dir);

    // The .ao file beside the model, as glint bake-ao writes it (values chosen, not baked, so
    // that the expected radiance is known at every pixel).
    render::Mesh mesh = render::load_model(model.string());
    render::AoFile file;
    file.model_name = "sphere.obj";
    file.model_checksum = render::file_checksum(model, &file.model_bytes);
    file.rays = 1;
    file.max_distance_relative = 2;
    for (const auto& p : mesh.positions) file.ao.push_back(float(ao_of(glm::dvec3(p))));
    render::save_ao_file(render::ao_path_for(model), file);
    render::AoLookup lookup = render::find_ao_for(model, mesh.positions.size());
    ASSERT_TRUE(lookup.used) << lookup.status;
    mesh.ao = lookup.ao;

    const HdrImage env = test::small_blender_world("courtyard");
    const render::Material m = render::parse_material("kd=0.6,0.5,0.4;ks=0.3;n=20");
    convolution::Options o;
    o.method = convolution::Method::Exact;
    o.size = convolution::Size{64, 32};
    const render::ShadingMaps maps = render::convolve_maps(env, m, o);

    render::Renderer r(mesh, m, maps, 256, 256);
    r.set_background_black();
    r.draw_scene();
    const render::Aovs with = r.read_aovs();
    const Error e = against(with, m, maps, true);
    std::printf("[          ] ao from the file: rms %.3e worst %.3e over %lld pixels\n", e.rms, e.worst, e.pixels);
    EXPECT_GT(e.pixels, 30000);
    EXPECT_LT(e.rms, 1e-3);
    EXPECT_LT(e.worst, 1e-2);
    // The same frame is far from the formula without ao: the test can tell.
    EXPECT_GT(against(with, m, maps, false).rms, 0.1);

    // --no-ao: ao = 1.
    r.set_ambient_occlusion(false);
    r.draw_scene();
    const Error off = against(r.read_aovs(), m, maps, false);
    std::printf("[          ] --no-ao: rms %.3e worst %.3e\n", off.rms, off.worst);
    EXPECT_LT(off.rms, 1e-3);
    EXPECT_LT(off.worst, 1e-2);
    fs::remove_all(dir);
}

TEST_F(RenderAo, SpecularTermIgnoresAo) {
    render::Mesh mesh = render::make_uv_sphere(48, 96);
    for (const auto& p : mesh.positions) mesh.ao.push_back(float(ao_of(glm::dvec3(p))));
    const HdrImage env = test::small_blender_world("studio");
    const render::Material m = render::parse_material("glossy:40");
    convolution::Options o;
    o.tolerance = 0.01;
    const render::ShadingMaps maps = render::convolve_maps(env, m, o);
    render::Renderer r(mesh, m, maps, 128, 128);
    r.set_background_black();
    r.draw_scene();
    const render::Aovs on = r.read_aovs();
    r.set_ambient_occlusion(false);
    r.draw_scene();
    const render::Aovs off = r.read_aovs();
    long long object = 0;
    for (std::size_t k = 0; k < on.radiance.size(); k += 4) object += on.radiance[k + 3] > 0;
    EXPECT_GT(object, 5000);
    EXPECT_EQ(on.radiance, off.radiance);
}

TEST_F(RenderAo, AoOfTheWrongLengthIsRefused) {
    render::Mesh mesh = render::make_uv_sphere(8, 16);
    mesh.ao.assign(3, 0.5f);
    const render::Material m = render::parse_material("matte");
    render::ShadingMaps maps;
    maps.irradiance = HdrImage(8, 4);
    EXPECT_THROW(render::Renderer(mesh, m, maps, 16, 16), InputError);
}

}  // namespace
}  // namespace glint
