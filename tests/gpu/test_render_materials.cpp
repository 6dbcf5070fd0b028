// Several materials on one model (docs/render.md, "Several materials"): an OBJ whose usemtl
// groups name two MTL materials (three groups: the first material twice) is drawn with one draw
// per distinct material, each group shaded with its own kd, ks and lobe, and the maps needed are
// exactly the distinct lobes.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <memory>
#include <unistd.h>

#include "appliance/convolution/convolution.hpp"
#include "appliance/core/errors.hpp"
#include "appliance/gl/gl_targets.hpp"
#include "appliance/render/maps.hpp"
#include "appliance/render/material.hpp"
#include "appliance/render/mesh.hpp"
#include "appliance/render/renderer.hpp"
#include "gpu_fixture.hpp"

namespace glint {
namespace {

namespace fs = std::filesystem;

class RenderMaterials : public test::GpuTest {};

// A unit sphere as OBJ: the upper hemisphere's triangles with x < 0 in group "paint", then the
// lower hemisphere in "chrome", then the rest of the upper one in "paint" again.
fs::path write_two_material_obj(const fs::path& dir) {
    std::ofstream(dir / "two.mtl") << "# two materials\nnewmtl paint\nKd 0.8 0.2 0.1\nKs 0 0 0\nNs 10\n"
                                      "newmtl chrome\nKd 0 0 0\nKs 0.5 0.25 0.125\nNs 160\n";
    const render::Mesh s = render::make_uv_sphere(16, 32);  // stacks even: no triangle crosses the equator
    std::ofstream obj(dir / "two.obj");
    obj << "mtllib two.mtl\n";
    for (std::size_t i = 0; i < s.positions.size(); ++i) {
        obj << "v " << s.positions[i].x << ' ' << s.positions[i].y << ' ' << s.positions[i].z << '\n';
        obj << "vn " << s.normals[i].x << ' ' << s.normals[i].y << ' ' << s.normals[i].z << '\n';
    }
    const auto group = [&](const char* name, auto&& keep) {
        obj << "usemtl " << name << '\n';
        for (std::size_t t = 0; t < s.indices.size(); t += 3) {
            const glm::vec3 c = (s.positions[s.indices[t]] + s.positions[s.indices[t + 1]] + s.positions[s.indices[t + 2]]) / 3.0f;
            if (!keep(c)) continue;
            obj << 'f';
            for (int k = 0; k < 3; ++k) obj << ' ' << s.indices[t + std::size_t(k)] + 1 << "//" << s.indices[t + std::size_t(k)] + 1;
            obj << '\n';
        }
    };
    group("paint", [](glm::vec3 c) { return c.y > 0 && c.x < 0; });
    group("chrome", [](glm::vec3 c) { return c.y <= 0; });
    group("paint", [](glm::vec3 c) { return c.y > 0 && c.x >= 0; });
    return dir / "two.obj";
}

TEST(ObjMaterialLibrary, OnlyAFileInTheModelsFolderIsRead) {
    const fs::path dir = fs::temp_directory_path() / ("glint_test_mtllib_" + std::to_string(::getpid()));
    fs::remove_all(dir);
    fs::create_directories(dir / "materials");
    std::ofstream(dir / "materials" / "m.mtl") << "newmtl red\nKd 0.9 0 0\n";
    const auto model = [&](const std::string& mtllib) {
        std::ofstream(dir / "m.obj") << "mtllib " << mtllib << "\nv 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl red\nf 1 2 3\n";
        return dir / "m.obj";
    };
    const render::Mesh inside = render::load_obj(model("materials/m.mtl"));
    ASSERT_EQ(inside.obj_materials.size(), 1u);
    EXPECT_DOUBLE_EQ(inside.obj_materials[0].kd.r, 0.9);
    for (const std::string bad : {"/dev/zero", "../m.mtl", "materials/../../m.mtl"}) {
        try {
            render::load_obj(model(bad));
            ADD_FAILURE() << "mtllib " << bad << " was read";
        } catch (const InputError& e) {
            EXPECT_NE(std::string(e.what()).find("must be a file in the model's folder"), std::string::npos) << e.what();
            EXPECT_NE(std::string(e.what()).find("m.obj"), std::string::npos) << e.what();
        }
    }
    fs::remove_all(dir);
}

TEST_F(RenderMaterials, EachUsemtlGroupIsShadedWithItsOwnMaterialOneDrawPerMaterial) {
    const fs::path dir = fs::temp_directory_path() / ("glint_test_render_materials_" + std::to_string(::getpid()));
    fs::remove_all(dir);
    fs::create_directories(dir);
    const render::Mesh mesh = render::load_obj(write_two_material_obj(dir));
    ASSERT_EQ(mesh.parts.size(), 3u);
    ASSERT_EQ(mesh.obj_materials.size(), 2u);
    EXPECT_EQ(mesh.parts[0].material, mesh.parts[2].material);
    EXPECT_TRUE(mesh.obj_materials[1].defined);
    EXPECT_EQ(mesh.parts[0].index_count + mesh.parts[1].index_count + mesh.parts[2].index_count, mesh.indices.size());

    const render::Material fallback = render::parse_material("matte");
    const std::vector<render::Material> materials = render::part_materials(mesh, fallback, false);
    ASSERT_EQ(materials.size(), 3u);
    EXPECT_EQ(materials[0].kd, glm::dvec3(0.8, 0.2, 0.1));
    EXPECT_FALSE(materials[0].specular());
    EXPECT_EQ(materials[1].ks, glm::dvec3(0.5, 0.25, 0.125));
    EXPECT_EQ(materials[1].n, 40.0);  // Ns / 4
    // Exactly the distinct lobes: the irradiance map and phong_40, each once.
    std::string labels;
    for (const auto& r : render::needed_maps(materials)) labels += r.label + " ";
    EXPECT_EQ(labels, "irradiance phong_40 ");
    // --material given: one material for every part.
    const std::vector<render::Material> all = render::part_materials(mesh, render::parse_material("glossy:20"), true);
    for (const auto& m : all) EXPECT_EQ(m.spec, "glossy:20");

    // Constant maps: the irradiance 1, the reflection 2, so each pixel's radiance says which
    // material shaded it: paint kd = (0.8, 0.2, 0.1), chrome 2 ks = (1, 0.5, 0.25).
    render::ShadingMaps maps;
    HdrImage one(16, 8), two(16, 8);
    for (auto& v : one.data()) v = 1.0f;
    for (auto& v : two.data()) v = 2.0f;
    maps.irradiance = one;
    maps.set_reflection(materials[1], two);
    render::Renderer r(mesh, materials, maps, 128, 96);
    EXPECT_EQ(r.draws(), 2u);
    r.draw_scene();
    const render::Aovs a = r.read_aovs();
    int paint = 0, chrome = 0;
    double worst = 0;
    for (std::size_t k = 0; k < std::size_t(a.width * a.height); ++k) {
        if (a.radiance[4 * k + 3] == 0) continue;
        const float ny = a.normal[4 * k + 1];
        if (std::abs(ny) < 0.02f) continue;  // the equator's pixels may belong to either
        const glm::dvec3 want = ny > 0 ? glm::dvec3(0.8, 0.2, 0.1) : glm::dvec3(1.0, 0.5, 0.25);
        (ny > 0 ? paint : chrome)++;
        for (int c = 0; c < 3; ++c) worst = std::max(worst, std::abs(a.radiance[4 * k + std::size_t(c)] - want[c]));
    }
    EXPECT_GT(paint, 2000);
    EXPECT_GT(chrome, 2000);
    EXPECT_LT(worst, 1e-5);

    // A group whose material no MTL defines falls back to the given material.
    std::ofstream(dir / "ghost.obj") << "v 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl ghost\nf 1 2 3\n";
    const render::Mesh ghost = render::load_obj(dir / "ghost.obj");
    ASSERT_EQ(ghost.parts.size(), 1u);
    EXPECT_FALSE(ghost.obj_materials[0].defined);
    EXPECT_EQ(render::part_materials(ghost, fallback, false).front().spec, "matte");
    fs::remove_all(dir);
}

// The kiosk's button: one renderer, its material switched between frames. After new maps arrive
// (replace_maps) the maps of the other materials are uploaded one per call of upload_pending_map;
// a switch draws with the new maps whether its map was uploaded yet or not.
TEST_F(RenderMaterials, SwitchingMaterialsAfterNewMapsDrawsWithTheNewMaps) {
    const render::Mesh sphere = render::make_uv_sphere(24, 48);
    const std::vector<render::Material> materials = {render::parse_material("matte"), render::parse_material("glossy:20"),
                                                     render::parse_material("mirror")};
    const auto room = [](float r, float g, float b) {
        HdrImage img(64, 32);
        for (int j = 0; j < 32; ++j)
            for (int i = 0; i < 64; ++i) img.set(i, j, {r * (1 + 0.02f * float(i)), g * (1 + 0.05f * float(j)), b});
        return img;
    };
    convolution::Options o;
    o.tolerance = 0.05;
    o.size = convolution::Size{32, 16};
    const render::ShadingMaps first = render::convolve_maps(room(0.2f, 0.3f, 0.4f), materials, o);
    const render::ShadingMaps second = render::convolve_maps(room(0.9f, 0.5f, 0.1f), materials, o);
    const auto radiance = [](render::Renderer& r) {
        r.draw_scene();
        return r.read_aovs().radiance;
    };
    // How the undrawn maps reach the GPU before the switches: not at all (uploaded at the switch),
    // in whole maps, in one row per call (every row), or three rows and no more (the switch
    // finishes the map under way and uploads the other).
    enum class Ahead { None, Whole, RowByRow, ThreeRows };
    std::size_t pending_rows = 0;  // the rows of glossy's and mirror's maps
    for (std::size_t k : {1u, 2u}) pending_rows += std::size_t(second.reflection_for(materials[k])->image.height());
    for (const Ahead ahead : {Ahead::None, Ahead::Whole, Ahead::RowByRow, Ahead::ThreeRows}) {
        const char* how = ahead == Ahead::None ? "uploaded at the switch" : ahead == Ahead::Whole ? "uploaded ahead"
                          : ahead == Ahead::RowByRow                       ? "uploaded ahead a row a call"
                                                                           : "three rows uploaded ahead";
        render::Renderer r(sphere, materials[0], first, 48, 36);
        EXPECT_FALSE(r.upload_pending_map());  // a new renderer has every map
        r.replace_maps(std::make_shared<const render::ShadingMaps>(second));
        std::size_t calls = 0;
        if (ahead == Ahead::Whole) {
            while (r.upload_pending_map()) ++calls;
            EXPECT_EQ(calls, 2u);  // glossy's and mirror's maps; matte's is drawn
        } else if (ahead == Ahead::RowByRow) {
            while (r.upload_pending_map(1)) ++calls;  // 1 byte: a row a call
            EXPECT_EQ(calls, pending_rows);
        } else if (ahead == Ahead::ThreeRows) {
            for (int k = 0; k < 3; ++k) EXPECT_TRUE(r.upload_pending_map(1));
        }
        for (std::size_t k : {2u, 1u, 0u}) {
            r.set_uniform_material(materials[k]);
            render::Renderer direct(sphere, materials[k], second, 48, 36);
            EXPECT_EQ(radiance(r), radiance(direct)) << materials[k].spec << ", " << how;
        }
        EXPECT_FALSE(r.upload_pending_map()) << how;
    }
}

// A map uploaded in bands (gl::TextureUpload) is the map uploaded at once, texel for texel: bands
// of one row, of a few rows that do not divide the height, and larger than the image.
TEST_F(RenderMaterials, AMapUploadedInBandsIsTheMapUploadedAtOnce) {
    HdrImage image(37, 23);  // odd sizes: rows not a multiple of 4 floats' alignment
    for (int j = 0; j < image.height(); ++j)
        for (int i = 0; i < image.width(); ++i) image.set(i, j, {float(i) + 0.25f, float(j) * 3.0f, float(i * j) - 7.5f});
    const auto texels = [&](const gl::GlTexture& t) {
        gl::GlFramebuffer fb = gl::GlFramebuffer::create();
        glBindFramebuffer(GL_FRAMEBUFFER, fb.id());
        glFramebufferTexture2D(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_TEXTURE_2D, t.id(), 0);
        std::vector<float> out(std::size_t(image.width()) * std::size_t(image.height()) * 4);
        glReadPixels(0, 0, image.width(), image.height(), GL_RGBA, GL_FLOAT, out.data());
        glBindFramebuffer(GL_FRAMEBUFFER, 0);
        return out;
    };
    const std::vector<float> whole = texels(gl::upload_image(image));
    ASSERT_EQ(whole[0], 0.25f);
    ASSERT_EQ(whole[4 * (std::size_t(image.width()) * 5 + 3) + 1], 15.0f);  // row 5, column 3: green 3 j
    ASSERT_EQ(whole[3], 1.0f);                                              // alpha
    const std::size_t row_bytes = std::size_t(image.width()) * 16;
    for (const std::size_t band : {std::size_t(1), 3 * row_bytes + 5, 1000 * row_bytes}) {
        gl::TextureUpload upload(image);
        EXPECT_THROW(upload.take(), RuntimeError);
        int steps = 1;
        while (!upload.step(band)) ++steps;
        const int rows = int(std::max<std::size_t>(1, band / row_bytes));
        EXPECT_EQ(steps, (image.height() + rows - 1) / rows) << band << " bytes a band";
        EXPECT_TRUE(upload.step(band));  // done stays done
        EXPECT_EQ(texels(upload.take()), whole) << band << " bytes a band";
    }
}

}  // namespace
}  // namespace glint
