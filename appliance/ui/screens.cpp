#include "appliance/ui/screens.hpp"

#include <algorithm>
#include <cfloat>
#include <cmath>
#include <numbers>
#include <string>
#include <vector>

#include <imgui.h>

namespace glint::ui {
namespace {

constexpr float kPi = std::numbers::pi_v<float>;

// Layout, in fractions of the frame's height H (the fonts scale with it too, imgui_layer.hpp).
constexpr float kMargin = 0.04f;          // from every edge
constexpr float kBarHeight = 0.035f;      // progress bars
constexpr float kDiscRadius = 0.11f;      // each hemisphere of the minimap
constexpr int kDiscTexels = 48;           // the minimap image's texels across a hemisphere
constexpr float kArrowInner = 0.10f;      // the arrow's tail, from the frame's centre
constexpr float kArrowOuter = 0.30f;      // its tip
constexpr float kArrowShaft = 0.055f;     // shaft width
constexpr float kArrowHead = 0.17f;       // head width (its length is kArrowHeadLength)
constexpr float kArrowHeadLength = 0.10f;
constexpr float kBreathPeriodS = 3.0f;    // ATTRACT's call grows and shrinks by kBreathAmount
constexpr float kBreathAmount = 0.035f;

constexpr ImU32 kPanel = IM_COL32(10, 12, 20, 165);     // behind every text, so it reads on any image
constexpr ImU32 kOutline = IM_COL32(10, 12, 20, 220);   // around the arrow and the minimap
constexpr ImU32 kUnseen = IM_COL32(45, 50, 62, 255);    // minimap: a cell never seen
constexpr ImU32 kCovered = IM_COL32(90, 220, 255, 255); // ... fully covered (255)
constexpr ImU32 kDim = IM_COL32(200, 200, 200, 190);    // the degraded mark
constexpr ImU32 kBanner = IM_COL32(25, 35, 70, 225);    // a friendly message

ImU32 with_alpha(ImU32 colour, float alpha) {
    const auto a = ImU32(std::clamp(alpha, 0.0f, 1.0f) * float((colour >> IM_COL32_A_SHIFT) & 0xFF) + 0.5f);
    return (colour & ~IM_COL32_A_MASK) | (a << IM_COL32_A_SHIFT);
}

// The model comes from estimators; a NaN there must not become a NaN polygon or an undefined
// integer conversion on screen.
double finite_or(double v, double fallback) { return std::isfinite(v) ? v : fallback; }
double unit_interval(double v) { return std::clamp(finite_or(v, 0.0), 0.0, 1.0); }

std::string seconds_text(double s) { return std::to_string(int(std::ceil(std::clamp(finite_or(s, 0.0), 0.0, 1e6)))); }

// What every screen draws with.
struct Painter {
    ImDrawList* list;
    ImGuiLayer& layer;
    const Strings& strings;
    float w, h, m;

    // The lines of `text` wrapped at `wrap` pixels, with their widths.
    struct Line {
        const char* begin;
        const char* end;
        float width;
    };
    std::vector<Line> wrap_lines(FontRole role, float size, const std::string& text, float wrap) const {
        ImFont* font = layer.font(role);
        const float scale = size / font->FontSize;
        std::vector<Line> lines;
        const char* s = text.c_str();
        const char* const end = s + text.size();
        while (s < end) {
            const char* stop = font->CalcWordWrapPositionA(scale, s, end, wrap);
            if (stop == s) stop = s + 1;  // a word wider than the line: cut it, never loop
            const char* line_end = stop;
            while (line_end > s && (line_end[-1] == ' ' || line_end[-1] == '\n')) --line_end;
            lines.push_back({s, line_end, font->CalcTextSizeA(size, FLT_MAX, 0.0f, s, line_end).x});
            s = stop;
            while (s < end && (*s == ' ' || *s == '\n')) ++s;
        }
        return lines;
    }

    // Centred, wrapped text on a dark panel whose top is at `top`; returns the panel's bottom.
    float panel_text(FontRole role, float size, const std::string& text, float centre_x, float top, ImU32 colour,
                     float wrap, ImU32 panel = kPanel) const {
        if (text.empty()) return top;
        const std::vector<Line> lines = wrap_lines(role, size, text, wrap);
        float widest = 0;
        for (const Line& l : lines) widest = std::max(widest, l.width);
        const float line_h = size * 1.15f, pad = size * 0.35f;
        const float height = line_h * float(lines.size());
        list->AddRectFilled(ImVec2(centre_x - widest / 2 - pad, top), ImVec2(centre_x + widest / 2 + pad, top + height + 2 * pad),
                            panel, pad);
        float y = top + pad;
        for (const Line& l : lines) {
            list->AddText(layer.font(role), size, ImVec2(std::round(centre_x - l.width / 2), std::round(y)), colour, l.begin,
                          l.end);
            y += line_h;
        }
        return top + height + 2 * pad;
    }

    // One line at (x, y), its left edge (align 0), centre (0.5) or right edge (1) at x.
    void text(FontRole role, float size, const std::string& t, float x, float y, ImU32 colour, float align = 0) const {
        const float width = layer.font(role)->CalcTextSizeA(size, FLT_MAX, 0.0f, t.c_str()).x;
        list->AddText(layer.font(role), size, ImVec2(std::round(x - width * align), std::round(y)), colour, t.c_str());
    }

    // A bar of `width` x `height` at (x, y): the track, then the filled part from the left, square
    // ends so that the filled width is exactly progress * width.
    void progress_bar(float x, float y, float width, float height, double progress) const {
        const float filled = width * float(unit_interval(progress));
        list->AddRectFilled(ImVec2(x - 3, y - 3), ImVec2(x + width + 3, y + height + 3), kOutline);
        list->AddRectFilled(ImVec2(x, y), ImVec2(x + width, y + height), colours::kTrack);
        if (filled > 0) list->AddRectFilled(ImVec2(x, y), ImVec2(x + filled, y + height), colours::kProgress);
    }
};

void draw_attract(const Painter& p, const ScreenModel& model) {
    const float t = float(model.t_s);
    const float breath = 1.0f + kBreathAmount * std::sin(2 * kPi * t / kBreathPeriodS);
    // The button: an amber disc with a ring that leaves it once per breath and fades.
    const ImVec2 button(p.w / 2, p.h * 0.40f);
    const float radius = p.h * 0.06f * breath;
    const float phase = std::fmod(t, kBreathPeriodS) / kBreathPeriodS;
    p.list->AddCircle(button, radius * (1.0f + 1.2f * phase), with_alpha(colours::kAccent, 1.0f - phase), 64, p.h * 0.008f);
    p.list->AddCircleFilled(button, radius + p.h * 0.008f, kOutline, 64);
    p.list->AddCircleFilled(button, radius, colours::kAccent, 64);

    const float size = p.layer.font_size(FontRole::Title) * breath;
    const float bottom = p.panel_text(FontRole::Title, size, p.strings.get("attract.call"), p.w / 2, p.h * 0.54f,
                                      colours::kText, p.w * 0.9f);
    p.panel_text(FontRole::Body, p.layer.font_size(FontRole::Body), p.strings.get("attract.subtitle"), p.w / 2,
                 bottom + p.m * 0.5f, colours::kText, p.w * 0.85f);
}

// The arrow from the centre towards (dx, dy) (screen axes, unit), or the "hold still" ring.
void draw_turn_arrow(const Painter& p, const CaptureView& view) {
    const ImVec2 c(p.w / 2, p.h / 2);
    double dx = finite_or(view.target_x, 0), dy = finite_or(view.target_y, 0);
    const double len = std::hypot(dx, dy);
    if (view.on_target || (len < 1e-6 && view.target_z > 0)) {
        const float r = p.h * 0.09f;
        p.list->AddCircle(c, r, kOutline, 64, p.h * 0.022f);
        p.list->AddCircle(c, r, colours::kProgress, 64, p.h * 0.012f);
        p.panel_text(FontRole::Body, p.layer.font_size(FontRole::Body), p.strings.get("capture.hold"), c.x,
                     c.y + r + p.m * 0.6f, colours::kText, p.w * 0.6f);
        return;
    }
    // Straight behind: any way round will do; the right, as a reader's eye goes.
    if (len < 1e-6) {
        dx = 1;
        dy = 0;
    } else {
        dx /= len;
        dy /= len;
    }
    const ImVec2 d{float(dx), float(dy)}, n{-float(dy), float(dx)};
    const auto at = [&](float along, float across) {
        return ImVec2(c.x + d.x * along + n.x * across, c.y + d.y * along + n.y * across);
    };
    const float r0 = p.h * kArrowInner, r1 = p.h * kArrowOuter, neck = r1 - p.h * kArrowHeadLength;
    const float shaft = p.h * kArrowShaft / 2, head = p.h * kArrowHead / 2;
    const ImVec2 outline[7] = {at(r0, -shaft), at(neck, -shaft), at(neck, -head), at(r1, 0),
                               at(neck, head),  at(neck, shaft),  at(r0, shaft)};
    p.list->AddPolyline(outline, 7, kOutline, ImDrawFlags_Closed, p.h * 0.012f);
    const ImVec2 body[4] = {outline[0], outline[1], outline[5], outline[6]};
    p.list->AddConvexPolyFilled(body, 4, colours::kAccent);
    p.list->AddTriangleFilled(outline[2], outline[3], outline[4], colours::kAccent);
}

// Two hemispheres seen from the middle of the room, as the visitor stands: the front one looking
// at -Z (the map's centre; +X right, +Y up) and the back one looking at +Z (-X right, +Y up). Each
// is an orthographic disc whose texels take the colour of the coverage cell their direction falls
// into; the view direction is a ring on the disc that holds it, the next target a dot. The discs
// are one small image (the layer's "minimap" texture) drawn magnified with linear filtering:
// four triangles instead of a square per cell, which llvmpipe draws ~1.4 ms faster.
void draw_minimap(const Painter& p, const CaptureView& view, float right, float bottom) {
    const float r = p.h * kDiscRadius, gap = p.h * 0.03f, pad = p.h * 0.015f;
    const ImVec2 front(right - 3 * r - gap, bottom - r), back(right - r, bottom - r);
    p.list->AddRectFilled(ImVec2(front.x - r - pad, front.y - r - pad), ImVec2(back.x + r + pad, back.y + r + pad), kPanel,
                          pad);
    // Each disc with a transparent texel around it, so that filtering never mixes the two.
    constexpr int texels = kDiscTexels, side_texels = texels + 2, image_w = 2 * side_texels, image_h = side_texels;
    std::vector<std::uint8_t> rgba(std::size_t(image_w) * image_h * 4);
    const ImVec4 unseen = ImGui::ColorConvertU32ToFloat4(kUnseen), covered = ImGui::ColorConvertU32ToFloat4(kCovered);
    for (int side = 0; side < 2; ++side) {
        const float mirror = side == 0 ? 1.0f : -1.0f;  // the back disc's right is -X
        for (int row = 0; row < side_texels; ++row) {
            for (int col = 0; col < side_texels; ++col) {
                std::uint8_t* t = &rgba[(std::size_t(row) * image_w + std::size_t(side * side_texels + col)) * 4];
                const float sx = (float(col - 1) + 0.5f) / float(texels) * 2 - 1;
                const float sy = (float(row - 1) + 0.5f) / float(texels) * 2 - 1;  // down on screen
                const float rr = sx * sx + sy * sy;
                // The share of the texel inside the disc, from its centre's distance to the rim.
                const float inside = std::clamp((1 - std::sqrt(rr)) * float(texels) / 2 + 0.5f, 0.0f, 1.0f);
                float c = 0;
                if (inside > 0) {
                    const float depth = std::sqrt(std::max(0.0f, 1 - rr));
                    c = float(minimap_cell(view, mirror * sx, -sy, side == 0 ? -depth : depth)) / 255.0f;
                }
                // Outside texels keep the unseen colour: filtering then darkens nothing at the rim.
                t[0] = std::uint8_t(std::lround(255 * (unseen.x + (covered.x - unseen.x) * c)));
                t[1] = std::uint8_t(std::lround(255 * (unseen.y + (covered.y - unseen.y) * c)));
                t[2] = std::uint8_t(std::lround(255 * (unseen.z + (covered.z - unseen.z) * c)));
                t[3] = std::uint8_t(std::lround(255 * inside));
            }
        }
    }
    void* const image = p.layer.image("minimap", image_w, image_h, rgba.data());
    const float u_texel = 1.0f / float(image_w), v_texel = 1.0f / float(image_h);
    for (int side = 0; side < 2; ++side) {
        const ImVec2 c = side == 0 ? front : back;
        const float u0 = float(side * side_texels + 1) * u_texel;
        p.list->AddImage(image, ImVec2(c.x - r, c.y - r), ImVec2(c.x + r, c.y + r), ImVec2(u0, v_texel),
                         ImVec2(u0 + float(texels) * u_texel, float(texels + 1) * v_texel));
        p.list->AddCircle(c, r + 1, kOutline, 64, 2.0f);
    }
    // Where a world direction lands: on the disc of its hemisphere, orthographically.
    const auto place = [&](double x, double y, double z, ImVec2& at) {
        const double n = std::sqrt(x * x + y * y + z * z);
        if (!(n > 0) || !std::isfinite(n)) return false;
        const bool on_back = z > 0;
        const ImVec2 c = on_back ? back : front;
        at = ImVec2(c.x + float((on_back ? -x : x) / n) * r, c.y - float(y / n) * r);
        return true;
    };
    ImVec2 at;
    if (place(view.next_x, view.next_y, view.next_z, at)) {  // the next target: a filled dot
        p.list->AddCircleFilled(at, r * 0.09f + 2.5f, kOutline, 24);
        p.list->AddCircleFilled(at, r * 0.09f, colours::kAccent, 24);
    }
    if (place(view.view_x, view.view_y, view.view_z, at)) {  // where the camera looks: a ring
        const float mr = r * 0.14f;
        p.list->AddCircle(at, mr, kOutline, 32, 5.0f);
        p.list->AddCircle(at, mr, colours::kAccent, 32, 2.5f);
    }
}

void draw_capture(const Painter& p, const ScreenModel& model, bool banner) {
    const CaptureView& v = model.capture;
    const float small = p.layer.font_size(FontRole::Small), body = p.layer.font_size(FontRole::Body);
    // The banner (drawn by the caller) takes the title's place at the top.
    float top = p.m + body * 1.15f + body * 0.7f;
    if (!banner) top = p.panel_text(FontRole::Body, body, p.strings.get("capture.title"), p.w / 2, p.m, colours::kText, p.w * 0.6f);

    // Exposure status, top left: a dot (green when fine, amber otherwise) and its words.
    const std::string exposure_key = "capture.exposure." + v.exposure;
    const std::string& exposure_text = p.strings.get(exposure_key);
    const float ew = p.layer.font(FontRole::Small)->CalcTextSizeA(small, FLT_MAX, 0.0f, exposure_text.c_str()).x;
    p.list->AddRectFilled(ImVec2(p.m - small * 0.3f, p.m - small * 0.3f), ImVec2(p.m + small * 1.5f + ew, p.m + small * 1.45f),
                          kPanel, small * 0.3f);
    p.list->AddCircleFilled(ImVec2(p.m + small * 0.5f, p.m + small * 0.58f), small * 0.35f,
                            v.exposure == "ok" ? colours::kProgress : colours::kAccent, 24);
    p.text(FontRole::Small, small, exposure_text, p.m + small * 1.2f, p.m, colours::kText);

    draw_turn_arrow(p, v);
    if (v.too_fast)
        p.panel_text(FontRole::Title, p.layer.font_size(FontRole::Title), p.strings.get("capture.slower"), p.w / 2,
                     top + p.m * 0.4f, colours::kAccent, p.w * 0.8f);

    // Bottom: the progress bar and its words on the left, the minimap on the right.
    const float minimap_w = 4 * p.h * kDiscRadius + p.h * 0.03f + 2 * p.h * 0.015f;
    draw_minimap(p, v, p.w - p.m - p.h * 0.015f, p.h - p.m - p.h * 0.015f);
    const float bar_h = p.h * kBarHeight, bar_y = p.h - p.m - bar_h;
    const float bar_x = p.m, bar_w = p.w - 3 * p.m - minimap_w;
    p.progress_bar(bar_x, bar_y, bar_w, bar_h, v.progress);
    const float words_y = bar_y - small * 1.55f;
    const std::string percent = std::to_string(int(std::lround(unit_interval(v.progress) * 100)));
    const std::string progress = p.strings.format("capture.progress", {{"percent", percent}});
    const std::string left = p.strings.format("capture.time_left", {{"s", seconds_text(v.time_left_s)}});
    p.list->AddRectFilled(ImVec2(bar_x - 3, words_y - small * 0.2f), ImVec2(bar_x + bar_w + 3, bar_y - 3), kPanel);
    p.text(FontRole::Small, small, progress, bar_x + small * 0.3f, words_y, colours::kText);
    p.text(FontRole::Small, small, left, bar_x + bar_w - small * 0.3f, words_y, colours::kText, 1.0f);
}

void draw_processing(const Painter& p, const ScreenModel& model) {
    const ProcessingView& v = model.processing;
    const float body = p.layer.font_size(FontRole::Body), small = p.layer.font_size(FontRole::Small);
    float y = p.panel_text(FontRole::Body, body, p.strings.get("processing.title"), p.w / 2, p.h * 0.58f, colours::kText,
                           p.w * 0.85f);
    if (!v.step.empty())
        y = p.panel_text(FontRole::Small, small, p.strings.get(v.step), p.w / 2, y + p.m * 0.4f, colours::kText, p.w * 0.8f);
    const float bar_w = p.w * 0.6f, bar_h = p.h * kBarHeight, bar_x = (p.w - bar_w) / 2, bar_y = y + p.m * 0.8f;
    p.progress_bar(bar_x, bar_y, bar_w, bar_h, v.progress);
    p.panel_text(FontRole::Small, small, p.strings.format("processing.time_left", {{"s", seconds_text(v.time_left_s)}}),
                 p.w / 2, bar_y + bar_h + p.m * 0.4f, colours::kText, p.w * 0.8f);
}

void draw_ar(const Painter& p, const ScreenModel& model) {
    const ArView& v = model.ar;
    const float body = p.layer.font_size(FontRole::Body), small = p.layer.font_size(FontRole::Small);
    // Bottom left: the material's name and the hint; the centre stays clear for the object.
    if (!v.material.empty()) {
        const std::string& name = p.strings.get(v.material);
        const std::string& hint = p.strings.get("ar.hint");
        const float nw = p.layer.font(FontRole::Body)->CalcTextSizeA(body, FLT_MAX, 0.0f, name.c_str()).x;
        const float hw = p.layer.font(FontRole::Small)->CalcTextSizeA(small, FLT_MAX, 0.0f, hint.c_str()).x;
        const float pad = small * 0.4f, top = p.h - p.m - body * 1.15f - small * 1.2f - 2 * pad;
        p.list->AddRectFilled(ImVec2(p.m, top), ImVec2(p.m + std::max(nw, hw) + 2 * pad, p.h - p.m), kPanel, pad);
        p.text(FontRole::Body, body, name, p.m + pad, top + pad, colours::kText);
        p.text(FontRole::Small, small, hint, p.m + pad, top + pad + body * 1.15f, colours::kText);
    }
    // Top right: the tracking mark. Green while the board is seen, amber while the sensor holds
    // the pose through a dropout (fading with visibility), a grey ring when lost.
    const float r = small * 0.45f;
    const std::string& words = p.strings.get(v.tracked ? "ar.tracking" : v.bridged ? "ar.tracking_held" : "ar.tracking_lost");
    const float ww = p.layer.font(FontRole::Small)->CalcTextSizeA(small, FLT_MAX, 0.0f, words.c_str()).x;
    const float right = p.w - p.m, pad = small * 0.3f;
    p.list->AddRectFilled(ImVec2(right - ww - 2 * r - 3 * pad, p.m - pad), ImVec2(right, p.m + small * 1.2f + pad), kPanel, pad);
    const ImVec2 dot(right - pad - r, p.m + small * 0.6f);
    if (v.tracked)
        p.list->AddCircleFilled(dot, r, colours::kProgress, 24);
    else if (v.bridged)
        p.list->AddCircleFilled(dot, r, with_alpha(colours::kAccent, 0.35f + 0.65f * float(unit_interval(v.visibility))), 24);
    else
        p.list->AddCircle(dot, r, kDim, 24, 2.0f);
    p.text(FontRole::Small, small, words, dot.x - r - pad, p.m, colours::kText, 1.0f);
}

}  // namespace

std::uint8_t minimap_cell(const CaptureView& view, double x, double y, double z) {
    const int w = view.minimap_width, h = view.minimap_height;
    if (w <= 0 || h <= 0 || view.minimap.size() < std::size_t(w) * std::size_t(h)) return 0;
    const double n = std::sqrt(x * x + y * y + z * z);
    if (!(n > 0)) return 0;
    // docs/conventions.md: phi = 2 pi u - pi from -Z towards +X, theta from +Y.
    const double phi = std::atan2(x, -z), theta = std::acos(std::clamp(y / n, -1.0, 1.0));
    const int i = std::clamp(int((phi + std::numbers::pi) / (2 * std::numbers::pi) * w), 0, w - 1);
    const int j = std::clamp(int(theta / std::numbers::pi * h), 0, h - 1);
    return view.minimap[std::size_t(j) * std::size_t(w) + std::size_t(i)];
}

void draw_visitor_screen(const ScreenModel& model, const Strings& strings, int width, int height) {
    ImGuiLayer& layer = ImGuiLayer::current();
    const float w = float(width), h = float(height);
    const Painter p{ImGui::GetForegroundDrawList(), layer, strings, w, h, h * kMargin};
    const bool banner = !model.message.empty();
    switch (model.state) {
        case KioskState::Attract: draw_attract(p, model); break;
        case KioskState::Capture: draw_capture(p, model, banner); break;
        case KioskState::Processing: draw_processing(p, model); break;
        case KioskState::Ar: draw_ar(p, model); break;
    }
    if (banner)
        p.panel_text(FontRole::Body, layer.font_size(FontRole::Body), strings.get(model.message), w / 2, p.m, colours::kText,
                     w * 0.8f, kBanner);
    if (model.sensor_lost || model.camera_lost) {
        // Over everything, with a turning arc: the kiosk waits for the device to come back.
        const float body = layer.font_size(FontRole::Body);
        const char* key = model.camera_lost ? "status.camera_lost" : "status.sensor_lost";
        const float bottom = p.panel_text(FontRole::Body, body, strings.get(key), w / 2, h * 0.5f - body,
                                          colours::kAccent, w * 0.8f);
        const ImVec2 c(w / 2, bottom + body);
        const float a0 = float(std::fmod(model.t_s, 1.5) / 1.5) * 2 * kPi;
        p.list->PathArcTo(c, body * 0.5f, a0, a0 + 1.5f * kPi, 32);
        p.list->PathStroke(colours::kAccent, ImDrawFlags_None, body * 0.12f);
    }
    if (model.degraded) {
        const float size = layer.font_size(FontRole::Small) * 0.7f;
        p.text(FontRole::Small, size, strings.get("status.degraded"), w / 2, h - size * 1.15f, kDim, 0.5f);
    }
}

}  // namespace glint::ui
