// The ImGui layer itself: fonts sized from the display, a clear error for a missing font file,
// keys pressed and released within one batch, and the GL state given back after drawing.
#include <gtest/gtest.h>

#include <GLES3/gl3.h>

#include <imgui.h>

#include "appliance/core/errors.hpp"
#include "appliance/ui/imgui_layer.hpp"
#include "tests/ui/ui_fixture.hpp"

using namespace glint;
using namespace glint::test;

class ImGuiLayerTest : public UiTest {};

TEST(FontSizes, VisitorTextReadsAtTwoMetresOn1080p) {
    const ui::FontSizes s = ui::font_sizes_for_height(1080);
    EXPECT_EQ(s.body, 60);
    EXPECT_EQ(s.title, 108);
    EXPECT_EQ(s.small, 36);
    EXPECT_EQ(s.menu, 27);
    EXPECT_EQ(ui::font_sizes_for_height(720).body, 40);
}

TEST_F(ImGuiLayerTest, AMissingFontFileIsNamed) {
    ui::FontFiles files;
    files.bold = "/nonexistent/DejaVuSans-Bold.ttf";
    try {
        ui::ImGuiLayer layer(640, 360, files);
        FAIL() << "expected an error";
    } catch (const RuntimeError& e) {
        EXPECT_NE(std::string(e.what()).find("/nonexistent/DejaVuSans-Bold.ttf"), std::string::npos) << e.what();
        EXPECT_NE(std::string(e.what()).find("fonts-dejavu-core"), std::string::npos) << e.what();
    }
}

TEST_F(ImGuiLayerTest, FontsAreLoadedAtTheirSizes) {
    EXPECT_FLOAT_EQ(layer().font(ui::FontRole::Body)->FontSize, 40.0f);
    EXPECT_FLOAT_EQ(layer().font(ui::FontRole::Title)->FontSize, 72.0f);
    EXPECT_FLOAT_EQ(layer().font(ui::FontRole::Menu)->FontSize, 18.0f);
    // The glyphs beyond ASCII the strings may use.
    EXPECT_NE(layer().font(ui::FontRole::Body)->FindGlyphNoFallback(0x2026), nullptr);  // ellipsis
    EXPECT_NE(layer().font(ui::FontRole::Body)->FindGlyphNoFallback(0x00E9), nullptr);  // e acute
}

TEST_F(ImGuiLayerTest, AKeyPressedAndReleasedInOneBatchIsSeenOnce) {
    using gl::InputEvent;
    layer().begin_frame(0.03, {{InputEvent::Type::KeyDown, "Return"}, {InputEvent::Type::KeyUp, "Return"}});
    EXPECT_TRUE(ImGui::IsKeyPressed(ImGui::GetKeyIndex(ImGuiKey_Enter)));
    layer().end_frame();
    layer().begin_frame(0.03, {});
    EXPECT_FALSE(ImGui::IsKeyDown(ImGui::GetKeyIndex(ImGuiKey_Enter)));
    layer().end_frame();
    // Held across batches: down until its release arrives.
    layer().begin_frame(0.03, {{InputEvent::Type::KeyDown, "Escape"}});
    layer().end_frame();
    layer().begin_frame(0.03, {});
    EXPECT_TRUE(ImGui::IsKeyDown(ImGui::GetKeyIndex(ImGuiKey_Escape)));
    layer().end_frame();
    layer().begin_frame(0.03, {{InputEvent::Type::KeyUp, "Escape"}});
    EXPECT_FALSE(ImGui::IsKeyDown(ImGui::GetKeyIndex(ImGuiKey_Escape)));
    layer().end_frame();
}

TEST_F(ImGuiLayerTest, GivesBackTheGlStateItChanges) {
    display().bind_frame();
    glDisable(GL_BLEND);
    glEnable(GL_DEPTH_TEST);
    glEnable(GL_SCISSOR_TEST);
    glScissor(10, 20, 30, 40);
    glViewport(0, 0, 640, 360);
    glUseProgram(0);
    layer().begin_frame(0.03, {});
    ImGui::GetForegroundDrawList()->AddRectFilled(ImVec2(0, 0), ImVec2(100, 100), IM_COL32(255, 0, 0, 128));
    layer().end_frame();
    EXPECT_GT(layer().last_frame().draw_calls, 0);
    EXPECT_FALSE(glIsEnabled(GL_BLEND));
    EXPECT_TRUE(glIsEnabled(GL_DEPTH_TEST));
    EXPECT_TRUE(glIsEnabled(GL_SCISSOR_TEST));
    GLint box[4] = {}, viewport[4] = {}, program = -1;
    glGetIntegerv(GL_SCISSOR_BOX, box);
    glGetIntegerv(GL_VIEWPORT, viewport);
    glGetIntegerv(GL_CURRENT_PROGRAM, &program);
    EXPECT_EQ(box[0], 10);
    EXPECT_EQ(box[3], 40);
    EXPECT_EQ(viewport[2], 640);
    EXPECT_EQ(program, 0);
    glDisable(GL_DEPTH_TEST);
    glDisable(GL_SCISSOR_TEST);
    EXPECT_EQ(glGetError(), GLenum(GL_NO_ERROR));
}

TEST_F(ImGuiLayerTest, BlendsStraightAlphaOverTheFrame) {
    // Half-transparent red over the stand-in frame: half of each.
    const gl::RgbImage plain = frame([] {});
    const gl::RgbImage over = frame([] {
        ImGui::GetForegroundDrawList()->AddRectFilled(ImVec2(100, 100), ImVec2(200, 200), IM_COL32(255, 0, 0, 128));
    });
    const Rgb under = pixel(plain, 150, 150), mixed = pixel(over, 150, 150);
    EXPECT_NEAR(mixed.r, under.r + (255 - under.r) * 128 / 255.0, 2);
    EXPECT_NEAR(mixed.g, under.g * (1 - 128 / 255.0), 2);
    // Outside the rectangle nothing changed; the rectangle's edges are where it says (y down).
    EXPECT_TRUE(near(pixel(over, 99, 150), pixel(plain, 99, 150), 0));
    EXPECT_FALSE(near(pixel(over, 100, 100), pixel(plain, 100, 100), 0));
    EXPECT_TRUE(near(pixel(over, 150, 200), pixel(plain, 150, 200), 0));
}
