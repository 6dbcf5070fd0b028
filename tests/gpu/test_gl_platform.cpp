// The GL platform: a context with what the engines need, every shader of
// shaders/ compiling and linking, clear errors for bad shaders.
#include <gtest/gtest.h>

#include <cstdio>
#include <filesystem>
#include <string>

#include "appliance/core/errors.hpp"
#include "appliance/gl/gl_objects.hpp"
#include "appliance/gl/gl_program.hpp"
#include "appliance/gl/shader_sources.hpp"
#include "gpu_fixture.hpp"

namespace glint::gl {
namespace {

using test::GpuTest;

// Files in the source tree's shaders/ whose names end in `suffix` ("" for all of them): what
// the build must have embedded (cmake/EmbedShaders.cmake).
int files_in_shaders(const std::string& suffix) {
    int count = 0;
    for (const auto& e : std::filesystem::directory_iterator(std::filesystem::path(GLINT_SOURCE_DIR) / "shaders")) {
        const std::string name = e.path().filename().string();
        if (e.is_regular_file() && name.size() >= suffix.size() &&
            name.compare(name.size() - suffix.size(), suffix.size(), suffix) == 0)
            ++count;
    }
    return count;
}

TEST_F(GpuTest, ContextIsOpenGlEs3WithFloatTargetsAndEightDrawBuffers) {
    const GlCapabilities& caps = context().caps();
    EXPECT_EQ(caps.major, 3);
    // The version the context reports must be the one its GL_VERSION string names ("OpenGL ES
    // 3.2 Mesa ..."), read here straight from GL; the engines' shaders need ES 3.0 or later.
    const char* version = reinterpret_cast<const char*>(glGetString(GL_VERSION));
    ASSERT_NE(version, nullptr);
    int major = -1, minor = -1;
    ASSERT_EQ(std::sscanf(version, "OpenGL ES %d.%d", &major, &minor), 2) << version;
    EXPECT_EQ(caps.major, major) << version;
    EXPECT_EQ(caps.minor, minor) << version;
    EXPECT_EQ(caps.version, version);
    EXPECT_TRUE(caps.float_color_buffer) << context().describe();
    EXPECT_GE(caps.max_draw_buffers, 8);
    EXPECT_NE(context().describe().find("float colour buffers yes"), std::string::npos);
}

// Every fragment shader links with its own vertex shader (same name) or, for
// the full-screen passes, with fullscreen.vert: a syntax error fails CI here.
TEST_F(GpuTest, EveryShaderCompilesAndLinks) {
    int fragments = 0;
    for (const ShaderSource& s : shader_sources()) {
        const std::string name(s.name);
        if (name.size() < 5 || name.substr(name.size() - 5) != ".frag") continue;
        const std::string stem = name.substr(0, name.size() - 5);
        std::string vertex = "fullscreen.vert";
        for (const ShaderSource& v : shader_sources())
            if (v.name == stem + ".vert") vertex = stem + ".vert";
        EXPECT_NO_THROW({ GlProgram p(vertex, name); }) << name;
        ++fragments;
    }
    // All of them: a build that embedded none (or only some) of shaders/ must not pass.
    EXPECT_EQ(fragments, files_in_shaders(".frag"));
    EXPECT_GT(fragments, 0);
}

TEST_F(GpuTest, EveryShaderFileIsEmbedded) {
    int embedded = 0;
    for (const ShaderSource& s : shader_sources()) {
        EXPECT_TRUE(std::filesystem::is_regular_file(std::filesystem::path(GLINT_SOURCE_DIR) / "shaders" / s.name))
            << s.name;
        ++embedded;
    }
    EXPECT_EQ(embedded, files_in_shaders(""));
}

TEST_F(GpuTest, EveryVertexShaderExpands) {
    int vertices = 0;
    for (const ShaderSource& s : shader_sources()) {
        const std::string name(s.name);
        if (name.size() < 5 || name.substr(name.size() - 5) != ".vert") continue;
        EXPECT_NO_THROW((void)shader_text(name)) << name;
        ++vertices;
    }
    EXPECT_EQ(vertices, files_in_shaders(".vert"));
    EXPECT_GT(vertices, 0);
}

TEST_F(GpuTest, UnknownShaderAndIncludeErrorsNameTheFile) {
    try {
        GlProgram p("fullscreen.vert", "no_such_shader.frag");
        FAIL() << "expected an error";
    } catch (const RuntimeError& e) {
        EXPECT_NE(std::string(e.what()).find("no_such_shader.frag"), std::string::npos) << e.what();
    }
}

TEST_F(GpuTest, DefinesAreInsertedAfterTheVersionLine) {
    const std::string text = shader_text("fullscreen.vert", {"GLINT_TEST 1"});
    ASSERT_EQ(text.rfind("#version 300 es\n#define GLINT_TEST 1\n", 0), 0u) << text.substr(0, 60);
}

TEST_F(GpuTest, RaiiReleasesNames) {
    GLuint id = 0;
    {
        GlTexture t = GlTexture::create();
        id = t.id();
        glBindTexture(GL_TEXTURE_2D, id);
        EXPECT_TRUE(glIsTexture(id));
        GlTexture moved = std::move(t);
        EXPECT_EQ(t.id(), 0u);
        EXPECT_EQ(moved.id(), id);
    }
    EXPECT_FALSE(glIsTexture(id));
}

}  // namespace
}  // namespace glint::gl
