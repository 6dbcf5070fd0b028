// The maintenance menu at 1280x720: the PIN page hands the typed digits to the kiosk's check and
// shows its answer, the pages draw, the keyboard reaches their buttons, the actions come back,
// and the test pattern has the right colours and 1-pixel lines.
#include <gtest/gtest.h>

#include <GLES3/gl3.h>
#include <imgui.h>

#include <filesystem>

#include "appliance/core/errors.hpp"
#include "appliance/ui/maintenance_menu.hpp"
#include "tests/ui/ui_fixture.hpp"

using namespace glint;
using namespace glint::test;
using glint::gl::InputEvent;
using Menu = glint::ui::MaintenanceMenu;
using Kind = glint::ui::MenuAction::Kind;

namespace {

const Rgb kWhite{255, 255, 255};
const Rgb kError{255, 120, 90};
const Rgb kGood{80, 210, 120};
const Rgb kWarn{255, 200, 0};

std::vector<InputEvent> press(std::initializer_list<const char*> keys) {
    std::vector<InputEvent> events;
    for (const char* k : keys) {
        events.push_back({InputEvent::Type::KeyDown, k});
        events.push_back({InputEvent::Type::KeyUp, k});
    }
    return events;
}

ui::MaintenanceStatus sample_status() {
    ui::MaintenanceStatus s;
    s.kiosk_state = "AR";
    s.sensor_health = "ok";
    s.sensor_ok = true;
    s.sensor_rate_hz = 99.8;
    s.camera_fps = 30.0;
    s.exposure_s = 0.008;
    s.gain = 1.5;
    s.display_mode = "headless: 1280x720 offscreen, llvmpipe";
    s.display_degraded = true;
    s.gl_renderer = "llvmpipe (LLVM 15.0.6, 256 bits)";
    s.cpu_temperature = "52.3 \xC2\xB0" "C";
    s.free_disk = "12.4 GB";
    s.uptime = "3 d 04:05:06";
    s.settings.capture.map_width = 1024;
    s.settings.capture.map_height = 512;
    s.log_lines = {"04:10:01 kiosk: ATTRACT -> CAPTURE", "04:11:40 capture: coverage 0.96, 118 frames",
                   "04:11:41 kiosk: CAPTURE -> PROCESSING", "04:11:43 convolution: 3 maps in 1.8 s",
                   "04:11:43 kiosk: PROCESSING -> AR"};
    s.export_targets = {"/media/usb (USB stick, 14.2 GB free)", "/media/usb2 (USB stick, 3.9 GB free)"};
    return s;
}

// Runs `frames` ImGui frames with the menu, the keys in the first; returns the image of the last
// and gathers every action.
struct MenuRun {
    gl::RgbImage image;
    std::vector<ui::MenuAction> actions;
};
MenuRun run(Menu& menu, const ui::MaintenanceStatus& status, const std::vector<InputEvent>& keys, int frames = 2,
        const std::string& name = "") {
    MenuRun r;
    int k = 0;
    r.image = UiTest::frame(
        [&] {
            const auto a = menu.draw(status, k++ == 0 ? keys : std::vector<InputEvent>{}, UiTest::strings(), kWidth, kHeight);
            r.actions.insert(r.actions.end(), a.begin(), a.end());
        },
        name, frames, keys);
    return r;
}

}  // namespace

class MenuTest : public UiTest {};

TEST_F(MenuTest, PinPageHandsTheTypedDigitsToTheCheck) {
    std::vector<std::string> asked;
    ui::PinAnswer answer{ui::PinAnswer::Kind::Wrong, 4, 0};
    Menu menu([&](const std::string& pin) {
        asked.push_back(pin);
        return answer;
    });
    menu.open();
    EXPECT_EQ(menu.page(), Menu::Page::Pin);
    const ui::MaintenanceStatus status = sample_status();
    run(menu, status, press({"1", "2", "3", "4", "Return"}));
    ASSERT_EQ(asked.size(), 1u);
    EXPECT_EQ(asked[0], "1234");
    EXPECT_EQ(menu.page(), Menu::Page::Pin);
    // The wrong PIN's answer in the error colour, two new digits as dots; saved as the screenshot.
    const MenuRun wrong = run(menu, status, press({"KP_7", "9", "BackSpace", "5"}), 2, "menu_pin");
    EXPECT_GT(count(wrong.image, kError, kWidth / 4, kHeight / 4, kWidth * 3 / 4, kHeight * 3 / 4, 2), 100);
    EXPECT_GT(count(wrong.image, kWhite, kWidth / 4, kHeight / 4, kWidth * 3 / 4, kHeight * 3 / 4, 2), 300);
    EXPECT_EQ(count(wrong.image, kWhite, 0, 0, kWidth / 5, kHeight, 2), 0);  // nothing but the PIN window
    run(menu, status, press({"KP_Enter"}));
    ASSERT_EQ(asked.size(), 2u);
    EXPECT_EQ(asked[1], "75");  // keypad digits count; BackSpace took the 9
    answer = {ui::PinAnswer::Kind::Locked, 0, 299.2};
    run(menu, status, press({"1", "Return"}));
    EXPECT_EQ(menu.page(), Menu::Page::Pin);
    answer = {ui::PinAnswer::Kind::Ok, 0, 0};
    run(menu, status, press({"2", "4", "6", "8", "Return"}));
    EXPECT_EQ(asked.back(), "2468");
    EXPECT_EQ(menu.page(), Menu::Page::Status);
    // Return with nothing typed asks nothing.
    menu.open();
    run(menu, status, press({"Return"}));
    EXPECT_EQ(asked.size(), 4u);
}

TEST_F(MenuTest, EscapeClosesAndFunctionKeysChoosePages) {
    Menu menu([](const std::string&) { return ui::PinAnswer{ui::PinAnswer::Kind::Ok, 0, 0}; });
    const ui::MaintenanceStatus status = sample_status();
    menu.open(true);  // the key switch: no PIN
    EXPECT_EQ(menu.page(), Menu::Page::Status);
    run(menu, status, press({"F4"}));
    EXPECT_EQ(menu.page(), Menu::Page::Log);
    run(menu, status, press({"Next"}));
    EXPECT_EQ(menu.page(), Menu::Page::Export);
    run(menu, status, press({"Prior", "Prior"}));
    EXPECT_EQ(menu.page(), Menu::Page::Settings);
    run(menu, status, press({"F7"}));
    EXPECT_EQ(menu.page(), Menu::Page::Pattern);
    run(menu, status, press({"Escape"}));  // from the pattern: back to Status
    EXPECT_EQ(menu.page(), Menu::Page::Status);
    EXPECT_TRUE(menu.is_open());
    const MenuRun closed = run(menu, status, press({"Escape"}));
    EXPECT_FALSE(menu.is_open());
    ASSERT_EQ(closed.actions.size(), 1u);
    EXPECT_EQ(closed.actions[0].kind, Kind::Close);
    // Closed: draws nothing, and a locked menu's pages cannot be chosen.
    menu.open();
    menu.set_page(Menu::Page::Status);
    EXPECT_EQ(menu.page(), Menu::Page::Pin);
}

TEST_F(MenuTest, StatusPageShowsTheValues) {
    Menu menu(nullptr);
    ui::MaintenanceStatus status = sample_status();
    menu.open(true);
    const MenuRun ok = run(menu, status, {}, 2, "menu_status");
    // The page list on the left, the table on the right, the sensor's health in green.
    EXPECT_GT(count(ok.image, kWhite, 0, 0, kWidth / 4, kHeight / 2, 2), 300);
    EXPECT_GT(count(ok.image, kWhite, kWidth / 4, 0, kWidth, kHeight / 2, 2), 1000);
    EXPECT_GT(count(ok.image, kGood, kWidth / 4, 0, kWidth, kHeight / 2, 2), 8);
    EXPECT_EQ(count(ok.image, kError, kWidth / 4, 0, kWidth, kHeight / 2, 2), 0);
    status.sensor_ok = false;
    status.sensor_health = "no samples for 2.1 s";
    const MenuRun bad = run(menu, status, {});
    EXPECT_GT(count(bad.image, kError, kWidth / 4, 0, kWidth, kHeight / 2, 2), 20);
    // The last scan's check of the camera-sensor calibration: none before a scan, amber when the
    // scan found it stale (its advice wrapped in the column).
    status = sample_status();
    status.display_degraded = false;  // the other amber row
    EXPECT_EQ(count(run(menu, status, {}).image, kWarn, kWidth / 4, 0, kWidth, kHeight, 2), 0);
    status.alignment_stale = true;
    status.alignment_check = "stale: the last scan turned its frames 2.98\xC2\xB0 from the calibration (mounting 2.94\xC2\xB0, time "
                             "offset +18.4 ms; limits 0.4\xC2\xB0, 7 ms). Its map used the scan's own values; the live view "
                             "did not. Run the sensor-camera alignment calibration.";
    const MenuRun stale = run(menu, status, {}, 2, "menu_status_alignment_stale");
    EXPECT_GT(count(stale.image, kWarn, kWidth / 4, 0, kWidth, kHeight, 2), 200);
}

TEST_F(MenuTest, CalibrationButtonsAreReachedByTheKeyboard) {
    Menu menu(nullptr);
    ui::MaintenanceStatus status = sample_status();
    menu.open(true);
    run(menu, status, press({"F2"}));  // the page opens with its first button focused
    const MenuRun start = run(menu, status, press({"space"}));
    ASSERT_EQ(start.actions.size(), 1u);
    EXPECT_EQ(start.actions[0].kind, Kind::StartCalibration);
    EXPECT_EQ(start.actions[0].calibration, ui::CalibrationKind::CameraIntrinsics);
    run(menu, status, press({"Down"}));
    run(menu, status, press({"Down"}));
    run(menu, status, press({"Down"}));
    const MenuRun align = run(menu, status, press({"space"}));
    ASSERT_EQ(align.actions.size(), 1u);
    EXPECT_EQ(align.actions[0].calibration, ui::CalibrationKind::Alignment);
    // While the alignment runs its button cancels it; the step and the result are shown.
    status.calibration_running = true;
    status.calibration = ui::CalibrationKind::Alignment;
    status.calibration_step = "Turn the device about its vertical axis (2 of 3)";
    status.calibration_result = "previous: 0.41 deg RMS";
    const MenuRun cancel = run(menu, status, press({"space"}), 2, "menu_calibrations");
    ASSERT_EQ(cancel.actions.size(), 1u);
    EXPECT_EQ(cancel.actions[0].kind, Kind::CancelCalibration);
}

TEST_F(MenuTest, CalibrationShowsTheLivePreviewTexture) {
    // An RGBA image (the camera's, in the kiosk) drawn through the layer's non-atlas path: the
    // texel's colour, not the atlas' coverage.
    std::vector<std::uint8_t> rgba(64 * 48 * 4);
    for (std::size_t k = 0; k < rgba.size(); k += 4) rgba[k] = 30, rgba[k + 1] = 160, rgba[k + 2] = 220, rgba[k + 3] = 255;
    gl::GlTexture texture = gl::GlTexture::create();
    glBindTexture(GL_TEXTURE_2D, texture.id());
    glTexImage2D(GL_TEXTURE_2D, 0, GL_RGBA8, 64, 48, 0, GL_RGBA, GL_UNSIGNED_BYTE, rgba.data());
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_LINEAR);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_LINEAR);
    Menu menu(nullptr);
    ui::MaintenanceStatus status = sample_status();
    menu.open(true);
    menu.set_page(Menu::Page::Calibrations);
    const Rgb camera{30, 160, 220};
    EXPECT_EQ(count(run(menu, status, {}).image, camera, 0, 0, kWidth, kHeight, 1), 0);
    status.calibration_running = true;
    status.calibration = ui::CalibrationKind::CameraIntrinsics;
    status.calibration_step = "Show the board at the top left (3 of 12)";
    status.calibration_preview_texture = texture.id();
    status.calibration_preview_width = 64;
    status.calibration_preview_height = 48;
    const gl::RgbImage image = run(menu, status, {}).image;
    // As wide as the page (about 900 pixels) at the image's 4:3, below the buttons.
    const int n = count(image, camera, kWidth / 4, kHeight / 4, kWidth, kHeight, 1);
    EXPECT_GT(n, 150000);
    EXPECT_LT(n, 900 * 675);
}

TEST_F(MenuTest, RestartNeedsTwoPresses) {
    Menu menu(nullptr);
    const ui::MaintenanceStatus status = sample_status();
    menu.open(true);
    run(menu, status, press({"F8"}));
    const MenuRun once = run(menu, status, press({"space"}));
    EXPECT_TRUE(once.actions.empty());
    const MenuRun twice = run(menu, status, press({"space"}), 2, "menu_restart");
    ASSERT_EQ(twice.actions.size(), 1u);
    EXPECT_EQ(twice.actions[0].kind, Kind::RestartKiosk);
}

TEST_F(MenuTest, ExportAsksForTheChosenTargetAndItems) {
    Menu menu(nullptr);
    ui::MaintenanceStatus status = sample_status();
    menu.open(true);
    run(menu, status, press({"F5"}));
    run(menu, status, press({"Down"}));                  // from the first target to the second
    run(menu, status, press({"space"}));                 // chosen
    for (int k = 0; k < 5; ++k) run(menu, status, press({"Down"}));  // four items, then the button
    status.export_result = "wrote 3 files (41 MB) to /media/usb2/glint-20261203-0440";
    const MenuRun exported = run(menu, status, press({"space"}), 2, "menu_export");
    ASSERT_EQ(exported.actions.size(), 1u);
    EXPECT_EQ(exported.actions[0].kind, Kind::Export);
    EXPECT_EQ(exported.actions[0].export_target, 1);
    EXPECT_EQ(exported.actions[0].export_items, ui::kExportEnvMap | ui::kExportMaps);
}

TEST_F(MenuTest, SettingsAreEditedAndApplied) {
    Menu menu(nullptr);
    const ui::MaintenanceStatus status = sample_status();
    menu.open(true);
    run(menu, status, press({"F3"}));
    // The page opens on the map width's field.
    run(menu, status, press({"Right"}));  // its "-"
    run(menu, status, press({"Right"}));  // its "+"
    run(menu, status, press({"space"}));  // 1024 + 256
    // Down the column of "+" buttons to Revert (the nearest beneath), then left to Apply.
    for (int k = 0; k < 5; ++k) run(menu, status, press({"Down"}));
    run(menu, status, press({"Left"}));
    const MenuRun applied = run(menu, status, press({"space"}), 2, "menu_settings");
    ASSERT_EQ(applied.actions.size(), 1u);
    EXPECT_EQ(applied.actions[0].kind, Kind::ApplySettings);
    EXPECT_EQ(applied.actions[0].settings.capture.map_width, 1280);
    EXPECT_EQ(applied.actions[0].settings.capture.map_height, 512);
}

TEST_F(MenuTest, EscapeWhileTypingANumberOnlyAbandonsTheTyping) {
    Menu menu(nullptr);
    const ui::MaintenanceStatus status = sample_status();
    menu.open(true);
    run(menu, status, press({"F3"}));                    // on the map width's field
    run(menu, status, press({"Return"}));                // typing into it
    run(menu, status, press({"2", "0", "4", "8"}));
    EXPECT_TRUE(ImGui::GetIO().WantTextInput);
    // WantTextInput follows a frame behind: three frames after the Escape it is settled.
    const MenuRun abandoned = run(menu, status, press({"Escape"}), 3);
    EXPECT_TRUE(menu.is_open());
    EXPECT_TRUE(abandoned.actions.empty());
    EXPECT_FALSE(ImGui::GetIO().WantTextInput);
    const MenuRun closed = run(menu, status, press({"Escape"}));
    EXPECT_FALSE(menu.is_open());
    ASSERT_EQ(closed.actions.size(), 1u);
    EXPECT_EQ(closed.actions[0].kind, Kind::Close);
}

TEST_F(MenuTest, LogButtonsAndLampPages) {
    Menu menu(nullptr);
    ui::MaintenanceStatus status = sample_status();
    menu.open(true);
    run(menu, status, press({"F4"}), 2, "menu_log");
    status.button_pressed = true;
    status.lamp = ui::LampMode::On;
    run(menu, status, press({"F6"}));     // on "Lamp on"
    run(menu, status, press({"Right"}));  // "Lamp off"
    const MenuRun lamp = run(menu, status, press({"space"}), 2, "menu_buttons");
    ASSERT_EQ(lamp.actions.size(), 1u);
    EXPECT_EQ(lamp.actions[0].kind, Kind::Lamp);
    EXPECT_EQ(lamp.actions[0].lamp, ui::LampMode::Off);
    EXPECT_GT(count(lamp.image, kGood, kWidth / 4, 0, kWidth, kHeight / 3, 2), 50);  // the button's pressed mark
}

TEST_F(MenuTest, TestPatternHasItsColoursAndOnePixelGrid) {
    Menu menu(nullptr);
    menu.open(true);
    menu.set_page(Menu::Page::Pattern);
    const gl::RgbImage image = run(menu, sample_status(), {}, 1, "menu_pattern").image;
    const Rgb bars[8] = {{255, 255, 255}, {255, 255, 0}, {0, 255, 255}, {0, 255, 0},
                         {255, 0, 255},   {255, 0, 0},   {0, 0, 255},   {0, 0, 0}};
    for (int k = 0; k < 8; ++k) {
        const int x = kWidth * (2 * k + 1) / 16;
        EXPECT_TRUE(near(pixel(image, x, kHeight / 4), bars[k], 0)) << "bar " << k;
        // Each bar is flat from its left to its right edge (the bar boundaries are whole pixels).
        EXPECT_TRUE(near(pixel(image, kWidth * k / 8 + 2, kHeight / 4), bars[k], 0)) << "bar " << k;
        EXPECT_TRUE(near(pixel(image, kWidth * (k + 1) / 8 - 2, kHeight / 4), bars[k], 0)) << "bar " << k;
    }
    // The ramp rises from left to right; the steps are 0, 17, ... 255.
    const int ramp_y = kHeight * 55 / 100, steps_y = kHeight * 65 / 100;
    EXPECT_LT(pixel(image, 10, ramp_y).r, 10);
    EXPECT_GT(pixel(image, kWidth - 10, ramp_y).r, 245);
    EXPECT_NEAR(pixel(image, kWidth / 2, ramp_y).r, 128, 4);
    for (int k = 0; k < 16; ++k) EXPECT_TRUE(near(pixel(image, kWidth * (2 * k + 1) / 32, steps_y), {k * 17, k * 17, k * 17}, 0));
    // The grid: a white column every 32 pixels, black beside it; the same for rows.
    const int grid_y = kHeight * 85 / 100 + 5;
    for (int x = 32; x < kWidth - 32; x += 32) {
        EXPECT_TRUE(near(pixel(image, x, grid_y), kWhite, 0)) << x;
        EXPECT_TRUE(near(pixel(image, x - 1, grid_y), {0, 0, 0}, 0)) << x;
        EXPECT_TRUE(near(pixel(image, x + 1, grid_y), {0, 0, 0}, 0)) << x;
    }
    int rows = 0;
    for (int y = kHeight * 7 / 10; y < kHeight - 1; ++y) rows += near(pixel(image, 16, y), kWhite, 0);
    EXPECT_EQ(rows, (kHeight - 1 - kHeight * 7 / 10 + 31) / 32);
    EXPECT_TRUE(near(pixel(image, kWidth - 1, kHeight / 4), kWhite, 0));  // the frame at the edge
    EXPECT_TRUE(near(pixel(image, kWidth / 3, kHeight - 1), kWhite, 0));
}

TEST_F(MenuTest, PinCheckFromThePinLockCountsDownAndLocks) {
    const std::filesystem::path dir = std::filesystem::temp_directory_path() / "glint_ui_menu_pin";
    std::filesystem::remove_all(dir);
    std::filesystem::create_directories(dir);
    ui::MaintenanceSection policy;
    policy.pin_hash = ui::hash_pin("2468");
    policy.max_attempts = 3;
    policy.lockout_s = 300;
    std::int64_t now_ns = 1'000'000'000;
    ui::PinLock lock(policy, dir / "pin_state.json", [](const ui::PinEvent&) {}, [&] { return now_ns; }, "boot-a");
    std::vector<ui::PinAnswer> answers;
    const ui::PinCheck lock_check = ui::pin_check_for(lock, policy.max_attempts);
    Menu menu([&](const std::string& pin) {
        answers.push_back(lock_check(pin));
        return answers.back();
    });
    const ui::MaintenanceStatus status = sample_status();
    menu.open();
    run(menu, status, press({"1", "1", "1", "1", "Return"}));
    run(menu, status, press({"2", "2", "2", "2", "Return"}));
    ASSERT_EQ(answers.size(), 2u);
    EXPECT_EQ(answers[0].kind, ui::PinAnswer::Kind::Wrong);
    EXPECT_EQ(answers[0].attempts_left, 2);
    EXPECT_EQ(answers[1].attempts_left, 1);
    run(menu, status, press({"3", "3", "3", "3", "Return"}));  // the third wrong PIN locks
    EXPECT_EQ(answers[2].kind, ui::PinAnswer::Kind::Locked);
    EXPECT_NEAR(answers[2].locked_s, 300, 1);
    now_ns += 100'000'000'000;  // 100 s later the right PIN is still refused
    run(menu, status, press({"2", "4", "6", "8", "Return"}));
    EXPECT_EQ(answers[3].kind, ui::PinAnswer::Kind::Locked);
    EXPECT_NEAR(answers[3].locked_s, 200, 1);
    EXPECT_EQ(menu.page(), Menu::Page::Pin);
    now_ns += 201'000'000'000;  // the lock-out is over
    run(menu, status, press({"2", "4", "6", "8", "Return"}));
    EXPECT_EQ(answers[4].kind, ui::PinAnswer::Kind::Ok);
    EXPECT_EQ(menu.page(), Menu::Page::Status);
}

TEST(MenuChord, FiresWhenTheKeyGoesDownWithItsModifiersHeld) {
    const auto down = [](const char* k) { return InputEvent{InputEvent::Type::KeyDown, k}; };
    const auto up = [](const char* k) { return InputEvent{InputEvent::Type::KeyUp, k}; };
    ui::MenuChord chord("ctrl+alt+m");
    EXPECT_FALSE(chord.feed({down("m"), up("m")}));                              // no modifiers
    EXPECT_FALSE(chord.feed({down("Control_L"), down("m"), up("m")}));           // ctrl only
    EXPECT_TRUE(chord.feed({down("Alt_R"), down("m")}));                         // ctrl still held from before
    EXPECT_FALSE(chord.feed({up("m"), up("Alt_R"), down("m")}));                 // alt released
    EXPECT_FALSE(chord.feed({up("m"), up("Control_L"), down("Alt_L"), down("m")}));
    EXPECT_TRUE(chord.feed({down("Control_R"), down("Shift_L"), down("M")}));   // more held, shift's capital
    // The left and right keys of a modifier are apart: releasing one keeps the other's.
    ui::MenuChord f("super+f2");
    EXPECT_TRUE(f.feed({down("Super_L"), down("Super_R"), up("Super_L"), down("F2")}));
    EXPECT_FALSE(f.feed({up("F2"), up("Super_R"), down("F2")}));
    EXPECT_FALSE(ui::MenuChord("").feed({down("Control_L"), down("Alt_L"), down("m")}));
}

TEST(MenuChord, ABadChordIsNamed) {
    for (const char* bad : {"m", "ctrl+", "hyper+m", "ctrl+alt+F13", "ctrl+Return", "ctrl+f0"}) {
        try {
            ui::MenuChord chord(bad);
            ADD_FAILURE() << bad << " was accepted";
        } catch (const InputError& e) {
            EXPECT_NE(std::string(e.what()).find(std::string("'") + bad + "'"), std::string::npos) << e.what();
        }
    }
}
