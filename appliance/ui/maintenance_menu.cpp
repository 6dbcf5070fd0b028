#include "appliance/ui/maintenance_menu.hpp"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <string_view>

#include <imgui.h>
#include <imgui_internal.h>  // SetFocusID: a new page's first button takes the keyboard focus

#include "appliance/core/errors.hpp"
#include "appliance/ui/imgui_layer.hpp"

namespace glint::ui {
namespace {

constexpr std::size_t kMaxPinDigits = 12;
constexpr double kConfirmWindowS = 5.0;  // Restart/Reboot: the second press must come within this

constexpr ImU32 kErrorColour = IM_COL32(255, 120, 90, 255);
constexpr ImU32 kGoodColour = IM_COL32(80, 210, 120, 255);
constexpr ImU32 kWarnColour = IM_COL32(255, 200, 0, 255);

struct PageInfo {
    MaintenanceMenu::Page page;
    const char* key;      // the strings key of its name
    const char* keysym;   // the function key that opens it
};
constexpr PageInfo kPages[] = {
    {MaintenanceMenu::Page::Status, "menu.page.status", "F1"},
    {MaintenanceMenu::Page::Calibrations, "menu.page.calibrations", "F2"},
    {MaintenanceMenu::Page::Settings, "menu.page.settings", "F3"},
    {MaintenanceMenu::Page::Log, "menu.page.log", "F4"},
    {MaintenanceMenu::Page::Export, "menu.page.export", "F5"},
    {MaintenanceMenu::Page::Buttons, "menu.page.buttons", "F6"},
    {MaintenanceMenu::Page::Pattern, "menu.page.pattern", "F7"},
    {MaintenanceMenu::Page::Restart, "menu.page.restart", "F8"},
};
constexpr int kPageCount = int(sizeof kPages / sizeof kPages[0]);

int page_index(MaintenanceMenu::Page page) {
    for (int k = 0; k < kPageCount; ++k)
        if (kPages[k].page == page) return k;
    return 0;
}

constexpr const char* kCalibrationKeys[kCalibrationKinds] = {"menu.calib.camera", "menu.calib.response",
                                                            "menu.calib.vignetting", "menu.calib.alignment",
                                                            "menu.calib.time_offset"};

// A digit typed on the main keys or the keypad, or 0.
char digit_of(std::string_view key) {
    if (key.size() == 1 && key[0] >= '0' && key[0] <= '9') return key[0];
    if (key.size() == 4 && key.substr(0, 3) == "KP_" && key[3] >= '0' && key[3] <= '9') return key[3];
    return 0;
}

std::string number_text(const char* format, double value) {
    char text[64];
    std::snprintf(text, sizeof text, format, value);
    return text;
}

// A label unique within its window: the visible text, then "###" and the id ImGui hashes alone,
// so that a button keeps its identity (and the keyboard focus) when its text changes.
std::string label(const std::string& text, const char* id) { return text + "###" + id; }

void status_row(const std::string& name, const std::string& value, ImU32 colour = IM_COL32_WHITE) {
    ImGui::TableNextRow();
    ImGui::TableSetColumnIndex(0);
    ImGui::TextUnformatted(name.c_str());
    ImGui::TableSetColumnIndex(1);
    ImGui::PushStyleColor(ImGuiCol_Text, colour);
    ImGui::PushTextWrapPos(0.0f);  // within the column: a stale calibration's advice is a sentence
    ImGui::TextUnformatted(value.c_str());
    ImGui::PopTextWrapPos();
    ImGui::PopStyleColor();
}

MenuAction action(MenuAction::Kind kind, CalibrationKind calibration = CalibrationKind::CameraIntrinsics) {
    MenuAction a;
    a.kind = kind;
    a.calibration = calibration;
    return a;
}

// Gives the keyboard focus to the item just submitted, highlighted as if the technician had moved
// there: a page opens with its first button focused, and space presses it at once.
void focus_item(ImGuiID id) {
    ImGuiContext& g = *ImGui::GetCurrentContext();
    ImGui::SetFocusID(id, g.CurrentWindow);
    g.NavDisableHighlight = false;
    g.NavDisableMouseHover = true;
}
// False while the window skips its items (its first frame, sizing itself): then try again.
bool focus_last_item() {
    ImGuiContext& g = *ImGui::GetCurrentContext();
    if (g.CurrentWindow->SkipItems || g.LastItemData.ID == 0) return false;
    focus_item(g.LastItemData.ID);
    return true;
}

}  // namespace

const char* menu_action_name(MenuAction::Kind kind) {
    switch (kind) {
        case MenuAction::Kind::Close: return "close";
        case MenuAction::Kind::StartCalibration: return "start-calibration";
        case MenuAction::Kind::CancelCalibration: return "cancel-calibration";
        case MenuAction::Kind::ApplyCalibration: return "apply-calibration";
        case MenuAction::Kind::ApplySettings: return "apply-settings";
        case MenuAction::Kind::Export: return "export";
        case MenuAction::Kind::Lamp: return "lamp";
        case MenuAction::Kind::RestartKiosk: return "restart-kiosk";
        case MenuAction::Kind::RebootAppliance: return "reboot-appliance";
    }
    return "?";
}

MaintenanceMenu::MaintenanceMenu(PinCheck check) : check_(std::move(check)) {}

void MaintenanceMenu::open(bool unlocked) {
    open_ = true;
    unlocked_ = unlocked;
    page_ = unlocked ? Page::Status : Page::Pin;
    page_changed_ = true;
    focus_pending_ = true;
    pin_.clear();
    pin_message_.clear();
    editing_ = false;
    armed_ = MenuAction::Kind::Close;
}

void MaintenanceMenu::close() {
    open_ = false;
    unlocked_ = false;
    pin_.clear();
}

void MaintenanceMenu::set_page(Page page) {
    if (!unlocked_ || page == Page::Pin || page == page_) return;
    page_ = page;
    page_changed_ = true;
    focus_pending_ = true;
    armed_ = MenuAction::Kind::Close;
}

void MaintenanceMenu::submit_pin() {
    if (pin_.empty()) return;
    const PinAnswer result = check_ ? check_(pin_) : PinAnswer{};
    pin_.clear();
    switch (result.kind) {
        case PinAnswer::Kind::Ok:
            unlocked_ = true;
            page_ = Page::Status;
            page_changed_ = true;
            focus_pending_ = true;
            pin_message_.clear();
            break;
        case PinAnswer::Kind::Wrong:
            pin_message_ = "wrong:" + std::to_string(result.attempts_left);
            break;
        case PinAnswer::Kind::Locked:
            pin_message_ = "locked:" + std::to_string(int(std::ceil(result.locked_s)));
            break;
        case PinAnswer::Kind::Disabled:
            pin_message_ = "disabled:";
            break;
    }
}

void MaintenanceMenu::handle_keys(const std::vector<gl::InputEvent>& keys, std::vector<MenuAction>& actions) {
    for (const gl::InputEvent& event : keys) {
        if (event.type != gl::InputEvent::Type::KeyDown || !open_) continue;
        const std::string& key = event.key;
        if (page_ == Page::Pin) {
            if (const char d = digit_of(key); d != 0 && pin_.size() < kMaxPinDigits) pin_ += d;
            else if (key == "BackSpace" && !pin_.empty()) pin_.pop_back();
            else if (key == "Return" || key == "KP_Enter") submit_pin();
            else if (key == "Escape") {
                close();
                actions.push_back(action(MenuAction::Kind::Close));
            }
            continue;
        }
        if (key == "Escape") {
            // While a number is being typed, Escape only abandons the typing (ImGui's own).
            // WantTextInput is from the frame before: the field was active when the key came.
            if (ImGui::GetIO().WantTextInput) continue;
            if (page_ == Page::Pattern) {
                set_page(Page::Status);
            } else {
                close();
                actions.push_back(action(MenuAction::Kind::Close));
            }
            continue;
        }
        for (const PageInfo& p : kPages)
            if (key == p.keysym) set_page(p.page);
        if (key == "Prior") set_page(kPages[(page_index(page_) + kPageCount - 1) % kPageCount].page);
        if (key == "Next") set_page(kPages[(page_index(page_) + 1) % kPageCount].page);
    }
}

std::vector<MenuAction> MaintenanceMenu::draw(const MaintenanceStatus& status, const std::vector<gl::InputEvent>& keys,
                                              const Strings& strings, int width, int height) {
    std::vector<MenuAction> actions;
    if (!open_) return actions;
    handle_keys(keys, actions);
    if (!open_) return actions;
    const ImGuiLayer& layer = ImGuiLayer::current();
    ImGui::PushFont(layer.font(FontRole::Menu));
    if (page_ == Page::Pin)
        draw_pin(strings, width, height);
    else if (page_ == Page::Pattern) {
        draw_test_pattern(width, height);
        const float size = layer.font_size(FontRole::Menu);
        const std::string& hint = strings.get("menu.pattern.hint");
        const ImVec2 extent = layer.font(FontRole::Menu)->CalcTextSizeA(size, 1e9f, 0.0f, hint.c_str());
        ImDrawList* list = ImGui::GetForegroundDrawList();
        const ImVec2 at(float(width) / 2 - extent.x / 2, float(height) - 3 * size);
        list->AddRectFilled(ImVec2(at.x - 6, at.y - 4), ImVec2(at.x + extent.x + 6, at.y + extent.y + 4), IM_COL32(0, 0, 0, 255));
        list->AddText(layer.font(FontRole::Menu), size, at, IM_COL32(160, 160, 160, 255), hint.c_str());
    } else
        draw_pages(status, strings, width, height, actions);
    ImGui::PopFont();
    page_changed_ = false;
    return actions;
}

void MaintenanceMenu::draw_pin(const Strings& s, int width, int height) {
    const float w = float(width), h = float(height), size = ImGui::GetFontSize();
    ImGui::SetNextWindowPos(ImVec2(w / 2, h / 2), ImGuiCond_Always, ImVec2(0.5f, 0.5f));
    ImGui::SetNextWindowSize(ImVec2(std::max(w * 0.4f, size * 22), 0));
    ImGui::SetNextWindowBgAlpha(0.95f);
    if (page_changed_) ImGui::SetNextWindowFocus();
    ImGui::Begin(label(s.get("menu.pin.title"), "pin").c_str(), nullptr,
                 ImGuiWindowFlags_NoResize | ImGuiWindowFlags_NoMove | ImGuiWindowFlags_NoCollapse |
                     ImGuiWindowFlags_NoSavedSettings | ImGuiWindowFlags_AlwaysAutoResize);
    ImGui::TextUnformatted(s.get("menu.pin.prompt").c_str());
    ImGui::Spacing();
    // One dot per digit typed, in boxes for the places still free (up to 6 shown empty).
    const ImVec2 origin = ImGui::GetCursorScreenPos();
    const float box = size * 1.6f;
    const std::size_t places = std::max<std::size_t>(pin_.size(), 6);
    ImDrawList* list = ImGui::GetWindowDrawList();
    for (std::size_t k = 0; k < places; ++k) {
        const ImVec2 a(origin.x + float(k) * (box + size * 0.4f), origin.y);
        list->AddRect(a, ImVec2(a.x + box, a.y + box), IM_COL32(200, 200, 200, 255), 4, 0, 2);
        if (k < pin_.size()) list->AddCircleFilled(ImVec2(a.x + box / 2, a.y + box / 2), box * 0.22f, IM_COL32_WHITE, 20);
    }
    ImGui::Dummy(ImVec2(float(places) * (box + size * 0.4f), box));
    ImGui::Spacing();
    if (pin_message_.rfind("wrong:", 0) == 0) {
        ImGui::PushStyleColor(ImGuiCol_Text, kErrorColour);
        ImGui::TextUnformatted(s.format("menu.pin.wrong", {{"n", pin_message_.substr(6)}}).c_str());
        ImGui::PopStyleColor();
    } else if (pin_message_.rfind("locked:", 0) == 0) {
        ImGui::PushStyleColor(ImGuiCol_Text, kErrorColour);
        ImGui::TextUnformatted(s.format("menu.pin.locked", {{"s", pin_message_.substr(7)}}).c_str());
        ImGui::PopStyleColor();
    } else if (pin_message_.rfind("disabled:", 0) == 0) {
        ImGui::PushStyleColor(ImGuiCol_Text, kErrorColour);
        ImGui::TextUnformatted(s.get("menu.pin.disabled").c_str());
        ImGui::PopStyleColor();
    } else {
        ImGui::TextUnformatted(" ");
    }
    ImGui::TextDisabled("%s", s.get("menu.close").c_str());
    ImGui::End();
}

void MaintenanceMenu::draw_pages(const MaintenanceStatus& status, const Strings& s, int width, int height,
                                 std::vector<MenuAction>& actions) {
    const float w = float(width), h = float(height), margin = h * 0.03f, list_w = std::max(w * 0.22f, ImGui::GetFontSize() * 11);
    const ImGuiWindowFlags fixed = ImGuiWindowFlags_NoResize | ImGuiWindowFlags_NoMove | ImGuiWindowFlags_NoCollapse |
                                   ImGuiWindowFlags_NoSavedSettings;
    // The page list: not a place the keyboard moves to (the function keys choose pages).
    ImGui::SetNextWindowPos(ImVec2(margin, margin));
    ImGui::SetNextWindowSize(ImVec2(list_w, h - 2 * margin));
    ImGui::SetNextWindowBgAlpha(0.95f);
    ImGui::Begin(label(s.get("menu.title"), "menu").c_str(), nullptr,
                 fixed | ImGuiWindowFlags_NoNav | ImGuiWindowFlags_NoBringToFrontOnFocus | ImGuiWindowFlags_NoFocusOnAppearing);
    for (const PageInfo& p : kPages) {
        const std::string text = std::string(p.keysym) + "  " + s.get(p.key);
        ImGui::Selectable(label(text, p.key).c_str(), page_ == p.page);
    }
    ImGui::SetCursorPosY(ImGui::GetWindowHeight() - ImGui::GetTextLineHeightWithSpacing() * 4);
    ImGui::PushTextWrapPos(0.0f);
    ImGui::TextDisabled("%s", s.get("menu.pages_hint").c_str());
    ImGui::PopTextWrapPos();
    ImGui::End();

    // The page: its own window, so that a new page takes the keyboard's focus and the first arrow
    // key lands on its first button.
    const PageInfo& info = kPages[page_index(page_)];
    ImGui::SetNextWindowPos(ImVec2(2 * margin + list_w, margin));
    ImGui::SetNextWindowSize(ImVec2(w - 3 * margin - list_w, h - 2 * margin));
    ImGui::SetNextWindowBgAlpha(0.95f);
    if (page_changed_) ImGui::SetNextWindowFocus();
    ImGui::Begin(label(s.get(info.key), info.key).c_str(), nullptr, fixed);
    switch (page_) {
        case Page::Status: draw_status(status, s); break;
        case Page::Calibrations: draw_calibrations(status, s, actions); break;
        case Page::Settings: draw_settings(status, s, actions); break;
        case Page::Log: draw_log(status, s); break;
        case Page::Export: draw_export(status, s, actions); break;
        case Page::Buttons: draw_buttons(status, s, actions); break;
        case Page::Restart: draw_restart(s, actions); break;
        case Page::Pin:
        case Page::Pattern: break;
    }
    ImGui::End();
}

void MaintenanceMenu::draw_status(const MaintenanceStatus& st, const Strings& s) {
    if (!ImGui::BeginTable("status", 2, ImGuiTableFlags_RowBg | ImGuiTableFlags_BordersInnerV)) return;
    ImGui::TableSetupColumn("name", ImGuiTableColumnFlags_WidthFixed, ImGui::GetFontSize() * 12);
    ImGui::TableSetupColumn("value", ImGuiTableColumnFlags_WidthStretch);
    status_row(s.get("menu.status.state"), st.kiosk_state);
    status_row(s.get("menu.status.sensor"), st.sensor_health, st.sensor_ok ? kGoodColour : kErrorColour);
    status_row(s.get("menu.status.sensor_rate"), number_text("%.1f Hz", st.sensor_rate_hz));
    status_row(s.get("menu.status.camera_fps"), number_text("%.1f fps", st.camera_fps));
    status_row(s.get("menu.status.exposure"), number_text("%.2f ms", st.exposure_s * 1e3));
    status_row(s.get("menu.status.gain"), number_text("%.2f", st.gain));
    status_row(s.get("menu.status.display"), st.display_mode + (st.display_degraded ? "  (" + s.get("status.degraded") + ")" : ""),
               st.display_degraded ? kWarnColour : IM_COL32_WHITE);
    status_row(s.get("menu.status.renderer"), st.gl_renderer);
    status_row(s.get("menu.status.cpu_temp"), st.cpu_temperature);
    status_row(s.get("menu.status.free_disk"), st.free_disk);
    status_row(s.get("menu.status.uptime"), st.uptime);
    status_row(s.get("menu.status.state_store"), st.state_store,
               !st.state_store_ok ? kErrorColour : st.state_store_warn ? kWarnColour : kGoodColour);
    status_row(s.get("menu.status.alignment"), st.alignment_check,
               st.alignment_stale ? kWarnColour : st.alignment_check == "n/a" ? IM_COL32_WHITE : kGoodColour);
    ImGui::EndTable();
}

void MaintenanceMenu::draw_calibrations(const MaintenanceStatus& st, const Strings& s, std::vector<MenuAction>& actions) {
    for (int k = 0; k < kCalibrationKinds; ++k) {
        const auto kind = CalibrationKind(k);
        const bool this_one = st.calibration_running && st.calibration == kind;
        ImGui::PushID(k);
        if (st.calibration_running && !this_one) ImGui::BeginDisabled();
        // One ID for Start and Cancel ("###run"): the focus stays on the button as it turns.
        const std::string text = s.get(this_one ? "menu.calib.cancel" : "menu.calib.start") + "###run";
        if (ImGui::Button(text.c_str(), ImVec2(ImGui::GetFontSize() * 6, 0)))
            actions.push_back(action(this_one ? MenuAction::Kind::CancelCalibration : MenuAction::Kind::StartCalibration, kind));
        if (k == 0 && focus_pending_ && focus_last_item()) focus_pending_ = false;
        if (st.calibration_running && !this_one) ImGui::EndDisabled();
        ImGui::SameLine();
        ImGui::TextUnformatted(s.get(kCalibrationKeys[k]).c_str());
        ImGui::PopID();
    }
    ImGui::Separator();
    ImGui::PushTextWrapPos(0.0f);
    if (st.calibration_running) {
        ImGui::Text("%s: %s", s.get(kCalibrationKeys[int(st.calibration)]).c_str(), s.get("menu.calib.step").c_str());
        ImGui::TextUnformatted(st.calibration_step.c_str());
        ImGui::ProgressBar(float(std::clamp(st.calibration_progress, 0.0, 1.0)), ImVec2(-1, 0));
    } else {
        ImGui::TextDisabled("%s", s.get("menu.calib.idle").c_str());
    }
    if (!st.calibration_result.empty()) ImGui::Text("%s: %s", s.get("menu.calib.result").c_str(), st.calibration_result.c_str());
    ImGui::PopTextWrapPos();
    // Apply keeps the result; it takes the keyboard focus when it appears, so that the technician
    // who started the wizard with the keyboard applies it with one more press.
    if (st.calibration_can_apply) {
        if (ImGui::Button((s.get("menu.calib.apply") + "###apply").c_str(), ImVec2(ImGui::GetFontSize() * 6, 0)))
            actions.push_back(action(MenuAction::Kind::ApplyCalibration, st.calibration));
        if (!apply_shown_ && focus_last_item()) apply_shown_ = true;
    } else {
        apply_shown_ = false;
    }
    if (st.calibration_preview_texture != 0 && st.calibration_preview_width > 0 && st.calibration_preview_height > 0) {
        // The live camera image, as wide as the page allows.
        const float avail = ImGui::GetContentRegionAvail().x, tall = ImGui::GetContentRegionAvail().y;
        const float aspect = float(st.calibration_preview_height) / float(st.calibration_preview_width);
        const float pw = std::min(avail, tall / aspect);
        ImGui::Image(reinterpret_cast<ImTextureID>(static_cast<std::uintptr_t>(st.calibration_preview_texture)),
                     ImVec2(pw, pw * aspect));
    }
}

void MaintenanceMenu::draw_settings(const MaintenanceStatus& st, const Strings& s, std::vector<MenuAction>& actions) {
    if (!editing_) edit_ = st.settings;  // follows the config until the technician changes something
    bool changed = false;
    ImGui::TextDisabled("%s", s.get("menu.settings.capture").c_str());
    ImGui::PushItemWidth(ImGui::GetFontSize() * 10);
    const std::string width_label = label(s.get("menu.settings.map_width"), "w");
    changed |= ImGui::InputInt(width_label.c_str(), &edit_.capture.map_width, 256, 1024);
    if (focus_pending_ && !ImGui::GetCurrentWindow()->SkipItems) {
        // The field itself, not the group InputInt ends with: InputScalar makes it as
        // InputText("") inside PushID(label).
        ImGui::PushID(width_label.c_str());
        const ImGuiID field = ImGui::GetID("");
        ImGui::PopID();
        focus_item(field);
        focus_pending_ = false;
    }
    changed |= ImGui::InputInt(label(s.get("menu.settings.map_height"), "h").c_str(), &edit_.capture.map_height, 128, 512);
    changed |= ImGui::InputDouble(label(s.get("menu.settings.target_coverage"), "cov").c_str(), &edit_.capture.target_coverage,
                                  0.01, 0.05, "%.2f");
    changed |= ImGui::InputDouble(label(s.get("menu.settings.max_scan_s"), "scan").c_str(), &edit_.capture.max_scan_s, 5, 30,
                                  "%.0f");
    ImGui::Spacing();
    ImGui::TextDisabled("%s", s.get("menu.settings.convolution").c_str());
    changed |= ImGui::InputDouble(label(s.get("menu.settings.tolerance"), "tol").c_str(), &edit_.convolution.tolerance, 0.001,
                                  0.01, "%.3f");
    ImGui::PopItemWidth();
    // Keeps the fields within ranges that make sense on the appliance; the kiosk still validates
    // what it applies, as it does the config file.
    edit_.capture.map_width = std::clamp(edit_.capture.map_width, 64, 8192);
    edit_.capture.map_height = std::clamp(edit_.capture.map_height, 32, 4096);
    edit_.capture.target_coverage = std::clamp(edit_.capture.target_coverage, 0.1, 1.0);
    edit_.capture.max_scan_s = std::clamp(edit_.capture.max_scan_s, 10.0, 600.0);
    edit_.convolution.tolerance = std::clamp(edit_.convolution.tolerance, 0.001, 0.5);
    editing_ = editing_ || changed;
    ImGui::Spacing();
    if (!editing_ || edit_ == st.settings) ImGui::BeginDisabled();
    const bool apply = ImGui::Button(s.get("menu.settings.apply").c_str());
    ImGui::SameLine();
    const bool revert = ImGui::Button(s.get("menu.settings.revert").c_str());
    if (!editing_ || edit_ == st.settings) ImGui::EndDisabled();
    if (apply) {
        MenuAction a = action(MenuAction::Kind::ApplySettings);
        a.settings = edit_;
        actions.push_back(a);
        editing_ = false;
    }
    if (revert) editing_ = false;
}

void MaintenanceMenu::draw_log(const MaintenanceStatus& st, const Strings& s) {
    ImGui::BeginChild("log", ImVec2(0, 0), false, ImGuiWindowFlags_HorizontalScrollbar);
    if (st.log_lines.empty()) ImGui::TextDisabled("%s", s.get("menu.log.empty").c_str());
    for (const std::string& line : st.log_lines) ImGui::TextUnformatted(line.c_str());
    // Newest at the bottom, in view unless the technician scrolled up.
    if (ImGui::GetScrollY() >= ImGui::GetScrollMaxY() - 1) ImGui::SetScrollHereY(1.0f);
    ImGui::EndChild();
}

void MaintenanceMenu::draw_export(const MaintenanceStatus& st, const Strings& s, std::vector<MenuAction>& actions) {
    ImGui::TextUnformatted(s.get("menu.export.target").c_str());
    if (st.export_targets.empty()) ImGui::TextDisabled("%s", s.get("menu.export.none").c_str());
    export_target_ = std::clamp(export_target_, 0, std::max(int(st.export_targets.size()) - 1, 0));
    for (std::size_t k = 0; k < st.export_targets.size(); ++k) {
        ImGui::RadioButton(label(st.export_targets[k], std::to_string(k).c_str()).c_str(), &export_target_, int(k));
        if (k == 0 && focus_pending_ && focus_last_item()) focus_pending_ = false;
    }
    ImGui::Spacing();
    const std::pair<ExportItem, const char*> items[] = {{kExportEnvMap, "menu.export.env_map"},
                                                        {kExportMaps, "menu.export.maps"},
                                                        {kExportScreenshots, "menu.export.screenshots"},
                                                        {kExportSessions, "menu.export.sessions"}};
    for (const auto& [bit, key] : items) {
        bool on = (export_items_ & bit) != 0;
        if (ImGui::Checkbox(s.get(key).c_str(), &on)) export_items_ = std::uint8_t(on ? export_items_ | bit : export_items_ & ~bit);
    }
    ImGui::Spacing();
    const bool possible = !st.export_targets.empty() && export_items_ != 0;
    if (!possible) ImGui::BeginDisabled();
    if (ImGui::Button(s.get("menu.export.start").c_str())) {
        MenuAction a = action(MenuAction::Kind::Export);
        a.export_target = export_target_;
        a.export_items = export_items_;
        actions.push_back(a);
    }
    if (!possible) ImGui::EndDisabled();
    if (!st.export_result.empty()) {
        ImGui::PushTextWrapPos(0.0f);
        ImGui::TextUnformatted(st.export_result.c_str());
        ImGui::PopTextWrapPos();
    }
}

void MaintenanceMenu::draw_buttons(const MaintenanceStatus& st, const Strings& s, std::vector<MenuAction>& actions) {
    const auto indicator = [&](const std::string& name, bool on) {
        const ImVec2 p = ImGui::GetCursorScreenPos();
        const float r = ImGui::GetFontSize() * 0.4f;
        ImGui::GetWindowDrawList()->AddCircleFilled(ImVec2(p.x + r, p.y + ImGui::GetFontSize() * 0.55f), r,
                                                    on ? kGoodColour : IM_COL32(90, 90, 90, 255), 20);
        ImGui::Dummy(ImVec2(2.5f * r, ImGui::GetFontSize()));
        ImGui::SameLine();
        ImGui::Text("%s: %s", name.c_str(), s.get(on ? "menu.buttons.pressed" : "menu.buttons.released").c_str());
    };
    indicator(s.get("menu.buttons.button"), st.button_pressed);
    indicator(s.get("menu.buttons.key_switch"), st.key_switch_on);
    ImGui::Spacing();
    const std::pair<LampMode, const char*> lamps[] = {
        {LampMode::On, "menu.buttons.lamp_on"}, {LampMode::Off, "menu.buttons.lamp_off"}, {LampMode::Blink, "menu.buttons.lamp_blink"}};
    for (const auto& [mode, key] : lamps) {
        const bool current = st.lamp == mode;
        if (current) ImGui::PushStyleColor(ImGuiCol_Button, ImGui::GetStyleColorVec4(ImGuiCol_ButtonActive));
        if (ImGui::Button(s.get(key).c_str())) {
            MenuAction a = action(MenuAction::Kind::Lamp);
            a.lamp = mode;
            actions.push_back(a);
        }
        if (mode == LampMode::On && focus_pending_ && focus_last_item()) focus_pending_ = false;
        if (current) ImGui::PopStyleColor();
        ImGui::SameLine();
    }
    ImGui::NewLine();
}

void MaintenanceMenu::draw_restart(const Strings& s, std::vector<MenuAction>& actions) {
    const double now = ImGui::GetTime();
    if (now - armed_at_ > kConfirmWindowS) armed_ = MenuAction::Kind::Close;
    const std::pair<MenuAction::Kind, const char*> choices[] = {{MenuAction::Kind::RestartKiosk, "menu.restart.kiosk"},
                                                                {MenuAction::Kind::RebootAppliance, "menu.restart.reboot"}};
    for (const auto& [kind, key] : choices) {
        const bool armed = armed_ == kind;
        if (armed) ImGui::PushStyleColor(ImGuiCol_Button, IM_COL32(170, 60, 40, 255));
        // Two presses: the first arms (and says so), the second within kConfirmWindowS acts.
        if (ImGui::Button(label(s.get(armed ? "menu.restart.confirm" : key), key).c_str(), ImVec2(ImGui::GetFontSize() * 16, 0))) {
            if (armed) {
                actions.push_back(action(kind));
                armed_ = MenuAction::Kind::Close;
            } else {
                armed_ = kind;
                armed_at_ = now;
            }
        }
        if (armed) ImGui::PopStyleColor();
        if (kind == MenuAction::Kind::RestartKiosk && focus_pending_ && focus_last_item()) focus_pending_ = false;
    }
}

MenuChord::MenuChord(const std::string& chord) {
    if (chord.empty()) return;
    std::vector<std::string> parts;
    for (std::size_t k = 0;;) {
        const std::size_t plus = chord.find('+', k);
        parts.push_back(chord.substr(k, plus == std::string::npos ? std::string::npos : plus - k));
        if (plus == std::string::npos) break;
        k = plus + 1;
    }
    const auto bad = [&](const std::string& why) {
        return InputError("maintenance chord '" + chord + "': " + why);
    };
    if (parts.size() < 2) throw bad("needs at least one modifier (ctrl, alt, shift, super) and a key");
    for (std::size_t p = 0; p + 1 < parts.size(); ++p) {
        const std::string& m = parts[p];
        const std::uint8_t bit = m == "ctrl" ? kCtrl : m == "alt" ? kAlt : m == "shift" ? kShift : m == "super" ? kSuper : 0;
        if (bit == 0) throw bad("'" + m + "' is not a modifier (ctrl, alt, shift, super)");
        wanted_ |= bit;
    }
    key_ = parts.back();
    const bool letter_or_digit = key_.size() == 1 && ((key_[0] >= 'a' && key_[0] <= 'z') || (key_[0] >= '0' && key_[0] <= '9'));
    const bool function_key = key_.size() >= 2 && key_.size() <= 3 && key_[0] == 'f' &&
                              key_.find_first_not_of("0123456789", 1) == std::string::npos &&
                              std::stoi(key_.substr(1)) >= 1 && std::stoi(key_.substr(1)) <= 12;
    if (!letter_or_digit && !function_key) throw bad("'" + key_ + "' is not a key a-z, 0-9 or f1-f12");
}

bool MenuChord::feed(const std::vector<gl::InputEvent>& events) {
    bool fired = false;
    for (const gl::InputEvent& e : events) {
        if (e.type == gl::InputEvent::Type::Quit) continue;
        const bool down = e.type == gl::InputEvent::Type::KeyDown;
        // X11 names the left and right modifier keys apart; either one holds the modifier.
        const std::string_view k = e.key;
        const bool right = k.size() > 2 && k.substr(k.size() - 2) == "_R";
        const std::string_view base = k.size() > 2 && (right || k.substr(k.size() - 2) == "_L") ? k.substr(0, k.size() - 2) : k;
        const std::uint8_t bit = base == "Control" ? kCtrl : (base == "Alt" || base == "Meta") ? kAlt
                               : base == "Shift" ? kShift : base == "Super" ? kSuper : 0;
        if (bit != 0) {
            std::uint8_t& side = right ? held_right_ : held_left_;
            side = std::uint8_t(down ? side | bit : side & ~bit);
            continue;
        }
        if (!down || key_.empty()) continue;
        std::string name(k);
        for (char& c : name) c = char(std::tolower(static_cast<unsigned char>(c)));  // "M" with shift, "F1"
        if (name == key_ && (std::uint8_t(held_left_ | held_right_) & wanted_) == wanted_) fired = true;
    }
    return fired;
}

void draw_test_pattern(int width, int height) {
    ImDrawList* list = ImGui::GetForegroundDrawList();
    const float w = float(width), h = float(height);
    // Integer pixel edges: each bar and line covers whole pixels, so its colour is exact.
    const auto x_at = [&](int k, int n) { return std::floor(w * float(k) / float(n)); };
    list->AddRectFilled(ImVec2(0, 0), ImVec2(w, h), IM_COL32(0, 0, 0, 255));
    const ImU32 bars[8] = {IM_COL32(255, 255, 255, 255), IM_COL32(255, 255, 0, 255), IM_COL32(0, 255, 255, 255),
                           IM_COL32(0, 255, 0, 255),     IM_COL32(255, 0, 255, 255), IM_COL32(255, 0, 0, 255),
                           IM_COL32(0, 0, 255, 255),     IM_COL32(0, 0, 0, 255)};
    const float bars_bottom = std::floor(h * 0.5f), ramp_bottom = std::floor(h * 0.6f), steps_bottom = std::floor(h * 0.7f);
    for (int k = 0; k < 8; ++k) list->AddRectFilled(ImVec2(x_at(k, 8), 0), ImVec2(x_at(k + 1, 8), bars_bottom), bars[k]);
    // A continuous ramp (the GPU interpolates across the rectangle) and 16 flat steps beneath.
    list->AddRectFilledMultiColor(ImVec2(0, bars_bottom), ImVec2(w, ramp_bottom), IM_COL32(0, 0, 0, 255),
                                  IM_COL32(255, 255, 255, 255), IM_COL32(255, 255, 255, 255), IM_COL32(0, 0, 0, 255));
    for (int k = 0; k < 16; ++k) {
        const int grey = k * 17;  // 0, 17, ... 255
        list->AddRectFilled(ImVec2(x_at(k, 16), ramp_bottom), ImVec2(x_at(k + 1, 16), steps_bottom),
                            IM_COL32(grey, grey, grey, 255));
    }
    // The 1-pixel grid every 32 pixels on black, and a 1-pixel frame at the very edges (overscan).
    const ImU32 white = IM_COL32(255, 255, 255, 255);
    for (int x = 0; x < width; x += 32) list->AddRectFilled(ImVec2(float(x), steps_bottom), ImVec2(float(x + 1), h), white);
    for (int y = int(steps_bottom); y < height; y += 32) list->AddRectFilled(ImVec2(0, float(y)), ImVec2(w, float(y + 1)), white);
    list->AddRectFilled(ImVec2(0, 0), ImVec2(w, 1), white);
    list->AddRectFilled(ImVec2(0, h - 1), ImVec2(w, h), white);
    list->AddRectFilled(ImVec2(0, 0), ImVec2(1, h), white);
    list->AddRectFilled(ImVec2(w - 1, 0), ImVec2(w, h), white);
}

}  // namespace glint::ui
