#include "appliance/ui/imgui_layer.hpp"

#include <GLES3/gl3.h>

#include <algorithm>
#include <array>
#include <cfloat>
#include <cmath>
#include <cstddef>
#include <string_view>

#include <imgui.h>
#include <imgui_freetype.h>
#include <imgui_internal.h>  // ImGuiContext::WithinFrameScope

#include "appliance/core/errors.hpp"
#include "appliance/gl/gl_context.hpp"
#include "appliance/gl/gl_objects.hpp"
#include "appliance/gl/gl_program.hpp"

namespace glint::ui {
namespace {

// The glyphs every font carries: Latin-1, the dashes, the typographic quotes, the ellipsis and
// the degree sign's neighbours. ImGui keeps the pointer until the atlas is built: static.
constexpr ImWchar kGlyphRanges[] = {0x0020, 0x00FF, 0x2013, 0x2014, 0x2018, 0x201F, 0x2026, 0x2026, 0x2190, 0x2193, 0};

// X11 keysym names to the KeysDown[] index ImGui's key map points at (ImGuiKey_* + 1: 0 is "no key").
struct NamedKey {
    std::string_view name;
    ImGuiKey_ key;
};
constexpr std::array kNamedKeys{
    NamedKey{"Tab", ImGuiKey_Tab},         NamedKey{"ISO_Left_Tab", ImGuiKey_Tab}, NamedKey{"Left", ImGuiKey_LeftArrow},
    NamedKey{"Right", ImGuiKey_RightArrow}, NamedKey{"Up", ImGuiKey_UpArrow},       NamedKey{"Down", ImGuiKey_DownArrow},
    NamedKey{"Prior", ImGuiKey_PageUp},    NamedKey{"Next", ImGuiKey_PageDown},    NamedKey{"Home", ImGuiKey_Home},
    NamedKey{"End", ImGuiKey_End},         NamedKey{"Insert", ImGuiKey_Insert},    NamedKey{"Delete", ImGuiKey_Delete},
    NamedKey{"BackSpace", ImGuiKey_Backspace}, NamedKey{"space", ImGuiKey_Space},  NamedKey{"Return", ImGuiKey_Enter},
    NamedKey{"Escape", ImGuiKey_Escape},   NamedKey{"KP_Enter", ImGuiKey_KeyPadEnter},
};
constexpr int key_index(ImGuiKey_ key) { return int(key) + 1; }
// Modifiers have their own indices above the named keys'.
constexpr int kCtrlIndex = ImGuiKey_COUNT + 1, kShiftIndex = ImGuiKey_COUNT + 2, kAltIndex = ImGuiKey_COUNT + 3;

int index_of(std::string_view name) {
    for (const NamedKey& k : kNamedKeys)
        if (k.name == name) return key_index(k.key);
    if (name == "Control_L" || name == "Control_R") return kCtrlIndex;
    if (name == "Shift_L" || name == "Shift_R") return kShiftIndex;
    if (name == "Alt_L" || name == "Alt_R") return kAltIndex;
    return 0;
}

// The character a key types, 0 for none: digits, letters, the keypad's digits, '.' and '-'
// (numbers in the settings page).
unsigned typed_character(std::string_view name) {
    if (name.size() == 1 && ((name[0] >= '0' && name[0] <= '9') || (name[0] >= 'a' && name[0] <= 'z') ||
                             (name[0] >= 'A' && name[0] <= 'Z')))
        return unsigned(name[0]);
    if (name.size() == 4 && name.substr(0, 3) == "KP_" && name[3] >= '0' && name[3] <= '9') return unsigned(name[3]);
    if (name == "period" || name == "KP_Decimal") return '.';
    if (name == "minus" || name == "KP_Subtract") return '-';
    return 0;
}

ImFont* add_font(ImFontAtlas& atlas, const std::filesystem::path& file, float size_px) {
    std::error_code error;
    if (!std::filesystem::is_regular_file(file, error))
        throw RuntimeError("font file " + file.string() + " is missing (Debian package fonts-dejavu-core)");
    ImFontConfig config;
    config.OversampleH = 1;  // FreeType hints the glyphs; oversampling is stb_truetype's remedy
    config.OversampleV = 1;
    ImFont* font = atlas.AddFontFromFileTTF(file.string().c_str(), size_px, &config, kGlyphRanges);
    if (font == nullptr) throw RuntimeError("font file " + file.string() + " could not be read");
    return font;
}

}  // namespace

FontSizes font_sizes_for_height(int height) {
    const float h = float(std::max(height, 1));
    return {std::round(h / 10.0f), std::round(h / 18.0f), std::round(h / 30.0f), std::round(h / 40.0f)};
}

struct ImGuiLayer::Renderer {
    gl::GlProgram program{"imgui.vert", "imgui.frag"};
    GLint u_frame_size = program.uniform("u_frame_size");
    GLint u_texture = program.uniform("u_texture");
    GLint u_coverage = program.uniform("u_coverage");
    gl::GlVertexArray vao = gl::GlVertexArray::create();
    gl::GlBuffer vertices = gl::GlBuffer::create();
    gl::GlBuffer indices = gl::GlBuffer::create();
    gl::GlTexture atlas = gl::GlTexture::create();
};

ImGuiLayer::ImGuiLayer(int width, int height, const FontFiles& fonts)
    : width_(width), height_(height), sizes_(font_sizes_for_height(height)) {
    if (width <= 0 || height <= 0)
        throw RuntimeError("ImGui layer: frame size " + std::to_string(width) + "x" + std::to_string(height));
    IMGUI_CHECKVERSION();
    ImGuiContext* previous = ImGui::GetCurrentContext();
    context_ = ImGui::CreateContext();
    ImGui::SetCurrentContext(context_);  // CreateContext keeps an earlier context current
    try {
        ImGuiIO& io = ImGui::GetIO();
        io.IniFilename = nullptr;  // the kiosk keeps no window layout between runs
        io.LogFilename = nullptr;
        io.ConfigFlags |= ImGuiConfigFlags_NavEnableKeyboard | ImGuiConfigFlags_NoMouseCursorChange;
        io.BackendFlags |= ImGuiBackendFlags_RendererHasVtxOffset;
        io.BackendRendererName = "glint_gles3";
        io.UserData = this;  // current(): the screens find their fonts through the context
        io.DisplaySize = ImVec2(float(width), float(height));
        for (const NamedKey& k : kNamedKeys) io.KeyMap[k.key] = key_index(k.key);
        io.MousePos = ImVec2(-FLT_MAX, -FLT_MAX);  // no pointer on the appliance

        ImFontAtlas& atlas = *io.Fonts;
        atlas.FontBuilderIO = ImGuiFreeType::GetBuilderForFreeType();
        atlas.FontBuilderFlags = ImGuiFreeTypeBuilderFlags_LightHinting;
        atlas.Flags |= ImFontAtlasFlags_NoMouseCursors;
        // Menu first: ImGui's windows use the atlas' first font by default.
        fonts_[int(FontRole::Menu)] = add_font(atlas, fonts.regular, sizes_.menu);
        fonts_[int(FontRole::Title)] = add_font(atlas, fonts.bold, sizes_.title);
        fonts_[int(FontRole::Body)] = add_font(atlas, fonts.regular, sizes_.body);
        fonts_[int(FontRole::Small)] = add_font(atlas, fonts.regular, sizes_.small);
        if (!atlas.Build())
            throw RuntimeError("FreeType could not rasterise " + fonts.regular.string() + " / " + fonts.bold.string());
        unsigned char* pixels = nullptr;
        int atlas_w = 0, atlas_h = 0;
        atlas.GetTexDataAsAlpha8(&pixels, &atlas_w, &atlas_h);
        GLint max_size = 0;
        glGetIntegerv(GL_MAX_TEXTURE_SIZE, &max_size);
        if (atlas_w > max_size || atlas_h > max_size)
            throw RuntimeError("ImGui layer: the font atlas for a " + std::to_string(height) + "-pixel display is " +
                               std::to_string(atlas_w) + "x" + std::to_string(atlas_h) + ", over the GL limit " +
                               std::to_string(max_size));

        renderer_ = std::make_unique<Renderer>();
        GLint previous_texture = 0, previous_alignment = 4;
        glGetIntegerv(GL_TEXTURE_BINDING_2D, &previous_texture);
        glGetIntegerv(GL_UNPACK_ALIGNMENT, &previous_alignment);
        glBindTexture(GL_TEXTURE_2D, renderer_->atlas.id());
        glPixelStorei(GL_UNPACK_ALIGNMENT, 1);
        glTexImage2D(GL_TEXTURE_2D, 0, GL_R8, atlas_w, atlas_h, 0, GL_RED, GL_UNSIGNED_BYTE, pixels);
        // Linear: the attract screen's call breathes in size, drawn between the atlas' pixels.
        glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_LINEAR);
        glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_LINEAR);
        glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_S, GL_CLAMP_TO_EDGE);
        glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_T, GL_CLAMP_TO_EDGE);
        glPixelStorei(GL_UNPACK_ALIGNMENT, previous_alignment);
        glBindTexture(GL_TEXTURE_2D, GLuint(previous_texture));
        atlas.SetTexID(reinterpret_cast<ImTextureID>(static_cast<std::uintptr_t>(renderer_->atlas.id())));
        // The CPU copy stays: ImGui 1.86 counts an atlas without it as not built (and Debian's
        // libimgui.a keeps its assertions).

        glBindVertexArray(renderer_->vao.id());
        glBindBuffer(GL_ARRAY_BUFFER, renderer_->vertices.id());
        glBindBuffer(GL_ELEMENT_ARRAY_BUFFER, renderer_->indices.id());
        glEnableVertexAttribArray(0);
        glEnableVertexAttribArray(1);
        glEnableVertexAttribArray(2);
        glBindVertexArray(0);
        gl::check_gl("creating the ImGui layer's GL objects");
    } catch (...) {
        renderer_.reset();
        ImGui::DestroyContext(context_);
        ImGui::SetCurrentContext(previous);
        throw;
    }
    ImGui::SetCurrentContext(previous == nullptr ? context_ : previous);
}

ImGuiLayer::~ImGuiLayer() {
    renderer_.reset();
    ImGui::DestroyContext(context_);  // also clears the current context when it was this one
}

const ImGuiLayer& ImGuiLayer::current() {
    const ImGuiContext* context = ImGui::GetCurrentContext();
    if (context == nullptr || !context->WithinFrameScope || ImGui::GetIO().UserData == nullptr)
        throw RuntimeError("ImGui layer: drawing outside begin_frame() / end_frame()");
    return *static_cast<const ImGuiLayer*>(ImGui::GetIO().UserData);
}

ImFont* ImGuiLayer::font(FontRole role) const { return fonts_[int(role)]; }

float ImGuiLayer::font_size(FontRole role) const {
    switch (role) {
        case FontRole::Title: return sizes_.title;
        case FontRole::Body: return sizes_.body;
        case FontRole::Small: return sizes_.small;
        case FontRole::Menu: return sizes_.menu;
    }
    return sizes_.body;
}

void ImGuiLayer::begin_frame(double dt_s, const std::vector<gl::InputEvent>& keys) {
    ImGui::SetCurrentContext(context_);
    ImGuiIO& io = ImGui::GetIO();
    io.DisplaySize = ImVec2(float(width_), float(height_));
    // ImGui divides by it and asserts it positive: a first frame or a replayed frame of no time.
    io.DeltaTime = dt_s > 1e-6 ? float(dt_s) : 1e-6f;
    for (int index : release_next_frame_) io.KeysDown[index] = false;
    release_next_frame_.clear();
    for (const gl::InputEvent& event : keys) {
        if (event.type == gl::InputEvent::Type::Quit) continue;
        const int index = index_of(event.key);
        const bool down = event.type == gl::InputEvent::Type::KeyDown;
        if (index != 0) {
            if (down) {
                io.KeysDown[index] = true;
                release_next_frame_.erase(std::remove(release_next_frame_.begin(), release_next_frame_.end(), index),
                                          release_next_frame_.end());
            } else if (io.KeysDown[index]) {
                // Pressed in an earlier batch: released now. Pressed in this batch: ImGui must
                // see it down for one frame first.
                bool pressed_now = false;
                for (const gl::InputEvent& e : keys) {
                    if (&e == &event) break;
                    if (e.type == gl::InputEvent::Type::KeyDown && index_of(e.key) == index) pressed_now = true;
                }
                if (pressed_now)
                    release_next_frame_.push_back(index);
                else
                    io.KeysDown[index] = false;
            }
        }
        if (down) {
            if (const unsigned c = typed_character(event.key); c != 0) io.AddInputCharacter(c);
        }
    }
    io.KeyCtrl = io.KeysDown[kCtrlIndex];
    io.KeyShift = io.KeysDown[kShiftIndex];
    io.KeyAlt = io.KeysDown[kAltIndex];
    ImGui::NewFrame();
}

void ImGuiLayer::end_frame() {
    ImGui::SetCurrentContext(context_);
    ImGui::Render();
    render();
}

void ImGuiLayer::render() {
    const ImDrawData* data = ImGui::GetDrawData();
    stats_ = {};
    if (data == nullptr || data->CmdListsCount == 0) return;
    const Renderer& r = *renderer_;

    // What we change, to give it back: the kiosk draws its 3D content with its own state.
    GLint program = 0, vao = 0, array_buffer = 0, texture = 0, active_texture = 0, viewport[4] = {}, scissor[4] = {};
    GLint blend_src_rgb = 0, blend_dst_rgb = 0, blend_src_alpha = 0, blend_dst_alpha = 0, blend_eq_rgb = 0,
          blend_eq_alpha = 0;
    glGetIntegerv(GL_CURRENT_PROGRAM, &program);
    glGetIntegerv(GL_VERTEX_ARRAY_BINDING, &vao);
    glGetIntegerv(GL_ARRAY_BUFFER_BINDING, &array_buffer);
    glGetIntegerv(GL_ACTIVE_TEXTURE, &active_texture);
    glActiveTexture(GL_TEXTURE0);
    glGetIntegerv(GL_TEXTURE_BINDING_2D, &texture);
    glGetIntegerv(GL_VIEWPORT, viewport);
    glGetIntegerv(GL_SCISSOR_BOX, scissor);
    glGetIntegerv(GL_BLEND_SRC_RGB, &blend_src_rgb);
    glGetIntegerv(GL_BLEND_DST_RGB, &blend_dst_rgb);
    glGetIntegerv(GL_BLEND_SRC_ALPHA, &blend_src_alpha);
    glGetIntegerv(GL_BLEND_DST_ALPHA, &blend_dst_alpha);
    glGetIntegerv(GL_BLEND_EQUATION_RGB, &blend_eq_rgb);
    glGetIntegerv(GL_BLEND_EQUATION_ALPHA, &blend_eq_alpha);
    const GLboolean blend = glIsEnabled(GL_BLEND), cull = glIsEnabled(GL_CULL_FACE), depth = glIsEnabled(GL_DEPTH_TEST),
                    stencil = glIsEnabled(GL_STENCIL_TEST), scissor_test = glIsEnabled(GL_SCISSOR_TEST);

    // Straight (not premultiplied) alpha, as ImGui's colours are; the frame's alpha accumulates
    // coverage, which nothing reads on a display.
    glEnable(GL_BLEND);
    glBlendEquation(GL_FUNC_ADD);
    glBlendFuncSeparate(GL_SRC_ALPHA, GL_ONE_MINUS_SRC_ALPHA, GL_ONE, GL_ONE_MINUS_SRC_ALPHA);
    glDisable(GL_CULL_FACE);
    glDisable(GL_DEPTH_TEST);
    glDisable(GL_STENCIL_TEST);
    glEnable(GL_SCISSOR_TEST);
    glViewport(0, 0, width_, height_);
    r.program.use();
    glUniform2f(r.u_frame_size, float(width_), float(height_));
    glUniform1i(r.u_texture, 0);
    glBindVertexArray(r.vao.id());
    glBindBuffer(GL_ARRAY_BUFFER, r.vertices.id());

    const GLuint atlas = r.atlas.id();
    GLuint bound_texture = 0;
    for (int n = 0; n < data->CmdListsCount; ++n) {
        const ImDrawList* list = data->CmdLists[n];
        glBufferData(GL_ARRAY_BUFFER, GLsizeiptr(list->VtxBuffer.Size) * GLsizeiptr(sizeof(ImDrawVert)),
                     list->VtxBuffer.Data, GL_STREAM_DRAW);
        glBufferData(GL_ELEMENT_ARRAY_BUFFER, GLsizeiptr(list->IdxBuffer.Size) * GLsizeiptr(sizeof(ImDrawIdx)),
                     list->IdxBuffer.Data, GL_STREAM_DRAW);
        unsigned bound_offset = ~0u;
        for (const ImDrawCmd& cmd : list->CmdBuffer) {
            if (cmd.UserCallback != nullptr) {
                // ImDrawCallback_ResetRenderState asks for our state again; nothing here uses it.
                if (cmd.UserCallback != ImDrawCallback_ResetRenderState) cmd.UserCallback(list, &cmd);
                continue;
            }
            // Clip rectangle in pixels, top-left origin; GL's scissor counts rows from the bottom.
            const float x0 = std::max(cmd.ClipRect.x, 0.0f), y0 = std::max(cmd.ClipRect.y, 0.0f);
            const float x1 = std::min(cmd.ClipRect.z, float(width_)), y1 = std::min(cmd.ClipRect.w, float(height_));
            if (x1 <= x0 || y1 <= y0 || cmd.ElemCount == 0) continue;
            glScissor(GLint(x0), GLint(float(height_) - y1), GLsizei(x1 - x0), GLsizei(y1 - y0));
            // Meshes over 64K vertices with 16-bit indices (ImGuiBackendFlags_RendererHasVtxOffset):
            // GLES 3.0 has no base vertex, so the attribute pointers start at the command's offset.
            if (cmd.VtxOffset != bound_offset) {
                bound_offset = cmd.VtxOffset;
                const std::size_t base = std::size_t(cmd.VtxOffset) * sizeof(ImDrawVert);
                glVertexAttribPointer(0, 2, GL_FLOAT, GL_FALSE, sizeof(ImDrawVert),
                                      reinterpret_cast<const void*>(base + offsetof(ImDrawVert, pos)));
                glVertexAttribPointer(1, 2, GL_FLOAT, GL_FALSE, sizeof(ImDrawVert),
                                      reinterpret_cast<const void*>(base + offsetof(ImDrawVert, uv)));
                glVertexAttribPointer(2, 4, GL_UNSIGNED_BYTE, GL_TRUE, sizeof(ImDrawVert),
                                      reinterpret_cast<const void*>(base + offsetof(ImDrawVert, col)));
            }
            const auto tex = GLuint(reinterpret_cast<std::uintptr_t>(cmd.GetTexID()));
            if (tex != bound_texture) {
                glBindTexture(GL_TEXTURE_2D, tex);
                glUniform1i(r.u_coverage, tex == atlas ? 1 : 0);
                bound_texture = tex;
            }
            glDrawElements(GL_TRIANGLES, GLsizei(cmd.ElemCount), sizeof(ImDrawIdx) == 2 ? GL_UNSIGNED_SHORT : GL_UNSIGNED_INT,
                           reinterpret_cast<const void*>(std::size_t(cmd.IdxOffset) * sizeof(ImDrawIdx)));
            stats_.triangles += int(cmd.ElemCount / 3);
            ++stats_.draw_calls;
        }
    }

    glBindVertexArray(GLuint(vao));
    glBindBuffer(GL_ARRAY_BUFFER, GLuint(array_buffer));
    glBindTexture(GL_TEXTURE_2D, GLuint(texture));
    glActiveTexture(GLenum(active_texture));
    glUseProgram(GLuint(program));
    glViewport(viewport[0], viewport[1], viewport[2], viewport[3]);
    glScissor(scissor[0], scissor[1], scissor[2], scissor[3]);
    glBlendEquationSeparate(GLenum(blend_eq_rgb), GLenum(blend_eq_alpha));
    glBlendFuncSeparate(GLenum(blend_src_rgb), GLenum(blend_dst_rgb), GLenum(blend_src_alpha), GLenum(blend_dst_alpha));
    const auto restore = [](GLenum cap, GLboolean on) { on ? glEnable(cap) : glDisable(cap); };
    restore(GL_BLEND, blend);
    restore(GL_CULL_FACE, cull);
    restore(GL_DEPTH_TEST, depth);
    restore(GL_STENCIL_TEST, stencil);
    restore(GL_SCISSOR_TEST, scissor_test);
    gl::check_gl("drawing the ImGui layer");
}

}  // namespace glint::ui
