// The visitor screens (docs/screens.md): what a ScreenModel shows, drawn with ImGui's foreground
// draw list over the 3D frame the kiosk drew beneath (the camera image, the object, the map
// filling in). Call between an ImGuiLayer's begin_frame and end_frame (its fonts are used); the
// texts come from `strings` by key.
//
//   ATTRACT     the call to press the button, breathing gently with t_s
//   CAPTURE     an arrow from the centre towards the next target (or a ring: hold still), the
//               coverage minimap (two hemispheres, the view direction marked), "slower", the
//               exposure status, a progress bar and the time left
//   PROCESSING  the step, a progress bar and the time left, low on the screen
//   AR          the material's name and a small tracking mark, in the corners: the centre stays clear
//   any state   a message banner (model.message), "sensor lost, please wait", a small
//               "degraded display" mark
#pragma once

#include <cstdint>

#include "appliance/ui/imgui_layer.hpp"
#include "appliance/ui/screen_model.hpp"
#include "appliance/ui/strings.hpp"

namespace glint::ui {

void draw_visitor_screen(const ScreenModel& model, const Strings& strings, int width, int height);

// The colours of the visitor screens (RGBA, 8 bits each), named for the tests and the docs.
namespace colours {
inline constexpr std::uint32_t kText = 0xFFFFFFFFu;        // white on a dark panel
inline constexpr std::uint32_t kAccent = 0xFF00C8FFu;      // ImGui packs ABGR: this is (255, 200, 0): amber
inline constexpr std::uint32_t kProgress = 0xFF78D250u;    // (80, 210, 120)
inline constexpr std::uint32_t kTrack = 0xFF503C32u;       // (50, 60, 80): the bar's unfilled part
}  // namespace colours

// The minimap's look-up: the coverage cell (0..255) that a world direction falls into, from an
// equirect of `width` x `height` cells, rows top first (docs/conventions.md). 0 when empty.
std::uint8_t minimap_cell(const CaptureView& view, double x, double y, double z);

}  // namespace glint::ui
