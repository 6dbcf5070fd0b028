// The displays (appliance/gl/display.hpp): the KMS connector and mode choice against made-up
// cards, the headless display's frames and PNGs, the window display under Xvfb (a screenshot and
// a key), and `auto`'s fallbacks on a machine without a DRM card.
#include <gtest/gtest.h>

#include <GLES3/gl3.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <thread>

#include "appliance/core/errors.hpp"
#include "appliance/gl/display.hpp"
#include "appliance/gl/kms_output.hpp"
#include "appliance/gl/png_writer.hpp"

// Xlib last: its macros (None, Bool, Status) collide with other headers' names.
#include <X11/Xlib.h>
#include <X11/Xutil.h>

namespace fs = std::filesystem;
using namespace glint;
using namespace glint::gl;

namespace {

KmsConnector connector(std::uint32_t id, const std::string& name, bool connected, std::vector<KmsMode> modes,
                       std::vector<std::uint32_t> crtcs = {31, 32}, std::uint32_t current = 0) {
    for (std::size_t i = 0; i < modes.size(); ++i) modes[i].index = int(i);
    return {id, name, connected, std::move(modes), std::move(crtcs), current};
}

// A card with a disconnected DSI panel and an HDMI monitor whose native mode is 1920x1080@60.
KmsCard two_connector_card() {
    KmsCard card;
    card.path = "/dev/dri/card1";
    card.connectors.push_back(connector(40, "DSI-1", false, {{800, 480, 60, true}}));
    card.connectors.push_back(connector(41, "HDMI-A-1", true,
                                        {{3840, 2160, 30, false}, {1920, 1080, 50, false}, {1920, 1080, 60, true},
                                         {1920, 1080, 59.94, false}, {1280, 720, 60, false}},
                                        {32}, 0));
    return card;
}

std::string error_of(const KmsCard& card, const KmsRequest& request) {
    try {
        choose_kms_output(card, request);
    } catch (const RuntimeError& e) {
        return e.what();
    }
    return "";
}

}  // namespace

TEST(KmsOutput, TakesTheConnectedConnectorAndItsPreferredMode) {
    const KmsCard card = two_connector_card();
    const KmsChoice c = choose_kms_output(card, {});
    EXPECT_EQ(card.connectors[c.connector].name, "HDMI-A-1");
    EXPECT_EQ(c.mode, 2u);  // 1920x1080@60, preferred, not the larger 4K
    EXPECT_EQ(c.crtc, 32u);
}

TEST(KmsOutput, HonoursTheConfigsModeAndRefresh) {
    const KmsCard card = two_connector_card();
    EXPECT_EQ(choose_kms_output(card, {"", "1280x720"}).mode, 4u);
    EXPECT_EQ(choose_kms_output(card, {"", "1920x1080@50"}).mode, 1u);
    EXPECT_EQ(choose_kms_output(card, {"", "1920x1080@59.94"}).mode, 3u);
    EXPECT_EQ(choose_kms_output(card, {"", "1920x1080"}).mode, 2u);  // the preferred of the three
    EXPECT_EQ(choose_kms_output(card, {"HDMI-A-1", "3840x2160"}).mode, 0u);
}

TEST(KmsOutput, WithoutAPreferredModeTakesTheLargest) {
    KmsCard card;
    card.path = "/dev/dri/card0";
    card.connectors.push_back(connector(7, "HDMI-A-2", true, {{1280, 720, 60, false}, {1920, 1080, 30, false},
                                                             {1920, 1080, 60, false}, {640, 480, 75, false}}));
    EXPECT_EQ(choose_kms_output(card, {}).mode, 2u);
}

TEST(KmsOutput, KeepsTheCrtcThatDrivesTheConnectorNow) {
    KmsCard card;
    card.path = "/dev/dri/card0";
    card.connectors.push_back(connector(7, "HDMI-A-1", true, {{1920, 1080, 60, true}}, {31, 32, 33}, 33));
    EXPECT_EQ(choose_kms_output(card, {}).crtc, 33u);
}

TEST(KmsOutput, EachFailureIsOneLineNamingTheCard) {
    const KmsCard card = two_connector_card();
    EXPECT_EQ(error_of(card, {"", "1024x768"}),
              "/dev/dri/card1: no such mode 1024x768 on HDMI-A-1 (it has 3840x2160@30.00, 1920x1080@50.00, "
              "1920x1080@60.00, 1920x1080@59.94, 1280x720@60.00)");
    EXPECT_EQ(error_of(card, {"", "1920x1080@75"}).rfind("/dev/dri/card1: no such mode 1920x1080@75 on HDMI-A-1", 0), 0u);
    EXPECT_EQ(error_of(card, {"", "big"}), "/dev/dri/card1: mode \"big\" is not WIDTHxHEIGHT or WIDTHxHEIGHT@HZ");
    EXPECT_EQ(error_of(card, {"DSI-1", ""}), "/dev/dri/card1: connector DSI-1 is not connected");
    EXPECT_EQ(error_of(card, {"DP-1", ""}), "/dev/dri/card1: no connector named DP-1 (the card has DSI-1, HDMI-A-1)");
    KmsCard dark = card;
    dark.connectors[1].connected = false;
    EXPECT_EQ(error_of(dark, {}), "/dev/dri/card1: no connected connector (is a display plugged in and on?)");
    KmsCard no_crtc;
    no_crtc.path = "/dev/dri/card2";
    no_crtc.connectors.push_back(connector(9, "HDMI-A-1", true, {{1920, 1080, 60, true}}, {}, 0));
    EXPECT_EQ(error_of(no_crtc, {}), "/dev/dri/card2: no CRTC can drive connector HDMI-A-1");
}

namespace {

constexpr std::uint32_t kXrgb8888 = 0x34325258;  // 'XR24'
constexpr std::uint32_t kArgb8888 = 0x34325241;  // 'AR24'

KmsPlane plane(std::uint32_t id, int type, std::uint32_t crtcs, std::vector<std::uint32_t> formats) {
    KmsPlane p;
    p.id = id;
    p.possible_crtcs = crtcs;
    p.formats = std::move(formats);
    p.properties["type"] = {id * 100 + 1, std::uint64_t(type)};
    return p;
}

// A card like a Raspberry Pi's: per CRTC a primary, overlays and a cursor; CRTC ids 60 and 61.
std::vector<KmsPlane> pi_like_planes() {
    return {plane(30, kPlaneTypeOverlay, 0b11, {kXrgb8888, kArgb8888}), plane(31, kPlaneTypeCursor, 0b01, {kArgb8888}),
            plane(32, kPlaneTypePrimary, 0b01, {kArgb8888}),             plane(33, kPlaneTypePrimary, 0b01, {kXrgb8888}),
            plane(34, kPlaneTypePrimary, 0b10, {kXrgb8888})};
}

std::string plane_error(const std::vector<KmsPlane>& planes, int crtc_index, std::uint32_t crtc_id) {
    try {
        choose_primary_plane("/dev/dri/card0", planes, crtc_index, crtc_id, kXrgb8888);
    } catch (const RuntimeError& e) {
        return e.what();
    }
    return "";
}

}  // namespace

TEST(KmsAtomic, TakesThePrimaryPlaneOfTheCrtcThatScansOutTheFormat) {
    const std::vector<KmsPlane> planes = pi_like_planes();
    // Not the overlay (30) though it can show XR24 on CRTC 0, not the primary without XR24 (32).
    EXPECT_EQ(planes[choose_primary_plane("/dev/dri/card0", planes, 0, 60, kXrgb8888)].id, 33u);
    EXPECT_EQ(planes[choose_primary_plane("/dev/dri/card0", planes, 1, 61, kXrgb8888)].id, 34u);
    EXPECT_EQ(fourcc_name(kXrgb8888), "XR24");
}

TEST(KmsAtomic, PrefersThePrimaryPlaneOnTheCrtcNow) {
    std::vector<KmsPlane> planes = pi_like_planes();
    planes.push_back(plane(35, kPlaneTypePrimary, 0b11, {kXrgb8888}));  // can serve both CRTCs
    planes.back().properties["CRTC_ID"] = {3501, 61};                    // and shows CRTC 61 now
    EXPECT_EQ(planes[choose_primary_plane("/dev/dri/card0", planes, 1, 61, kXrgb8888)].id, 35u);
    EXPECT_EQ(planes[choose_primary_plane("/dev/dri/card0", planes, 0, 60, kXrgb8888)].id, 33u);  // the first that fits
}

TEST(KmsAtomic, EachPlaneFailureIsOneLineNamingTheCardAndCrtc) {
    std::vector<KmsPlane> planes = pi_like_planes();
    planes.erase(planes.begin() + 3);  // CRTC 0's XR24 primary gone: 32 remains, AR24 only
    EXPECT_EQ(plane_error(planes, 0, 60), "/dev/dri/card0: no primary plane for CRTC 60 that scans out XR24");
    EXPECT_EQ(plane_error(planes, 2, 62), "/dev/dri/card0: no primary plane for CRTC 62");
    EXPECT_EQ(plane_error({}, 0, 60), "/dev/dri/card0: no planes (the driver lists none with universal planes on)");
    EXPECT_EQ(plane_error(planes, 40, 99), "/dev/dri/card0: CRTC 99 is not among the first 32 a plane can name");
}

TEST(KmsAtomic, ModesetSetsConnectorCrtcAndAWholePlaneAndAFlipOnlyTheFramebuffer) {
    const AtomicOutput out{41, 60, 33, 1920, 1080, {}};
    const std::vector<AtomicSet> first = atomic_modeset(out, 77, 500);
    std::map<std::string, std::uint64_t> plane_values;
    for (const AtomicSet& s : first) {
        if (s.object == 33) plane_values[s.property] = s.value;
        if (s.object == 41) {
            EXPECT_EQ(s.property, "CRTC_ID");
            EXPECT_EQ(s.value, 60u);
        }
    }
    EXPECT_EQ(plane_values["FB_ID"], 500u);
    EXPECT_EQ(plane_values["CRTC_ID"], 60u);
    EXPECT_EQ(plane_values["SRC_W"], 1920u << 16);  // 16.16 fixed point
    EXPECT_EQ(plane_values["SRC_H"], 1080u << 16);
    EXPECT_EQ(plane_values["CRTC_W"], 1920u);
    EXPECT_EQ(plane_values["CRTC_H"], 1080u);
    EXPECT_EQ(plane_values.size(), 10u);
    // Planes another master left on the CRTC are switched off by the mode set.
    AtomicOutput with_cursor = out;
    with_cursor.planes_off = {31};
    std::map<std::string, std::uint64_t> cursor_values;
    for (const AtomicSet& s : atomic_modeset(with_cursor, 77, 500))
        if (s.object == 31) cursor_values[s.property] = s.value;
    EXPECT_EQ(cursor_values, (std::map<std::string, std::uint64_t>{{"CRTC_ID", 0}, {"FB_ID", 0}}));
    const std::vector<AtomicSet> flip = atomic_flip(out, 501);
    ASSERT_EQ(flip.size(), 1u);
    EXPECT_EQ(flip[0].object, 33u);
    EXPECT_EQ(flip[0].property, "FB_ID");
    EXPECT_EQ(flip[0].value, 501u);
}

TEST(KmsAtomic, ResolvesPropertyNamesAndNamesTheOneMissing) {
    const AtomicOutput out{41, 60, 33, 800, 480, {}};
    std::map<std::uint32_t, KmsProperties> props;
    std::uint32_t next = 1000;
    props[41]["CRTC_ID"] = {next++, 0};
    for (const char* name : {"MODE_ID", "ACTIVE"}) props[60][name] = {next++, 0};
    for (const char* name : {"FB_ID", "CRTC_ID", "SRC_X", "SRC_Y", "SRC_W", "SRC_H", "CRTC_X", "CRTC_Y", "CRTC_W"})
        props[33][name] = {next++, 0};
    const auto error = [&] {
        try {
            resolve_atomic("/dev/dri/card0", atomic_modeset(out, 5, 6), props);
        } catch (const RuntimeError& e) {
            return std::string(e.what());
        }
        return std::string();
    };
    EXPECT_EQ(error(), "/dev/dri/card0: plane 33 has no property CRTC_H");
    props[33]["CRTC_H"] = {next++, 0};
    const std::vector<AtomicIds> ids = resolve_atomic("/dev/dri/card0", atomic_modeset(out, 5, 6), props);
    ASSERT_EQ(ids.size(), 13u);
    EXPECT_EQ(ids[0].object, 41u);
    EXPECT_EQ(ids[0].property, props[41]["CRTC_ID"].id);
    EXPECT_EQ(ids[0].value, 60u);
    EXPECT_EQ(ids.back().property, props[33]["CRTC_H"].id);
    EXPECT_EQ(ids.back().value, 480u);
    props.erase(60);
    EXPECT_EQ(error(), "/dev/dri/card0: CRTC 60 has no properties");
}

TEST(Png, RoundTripsAndRejectsTruncatedFiles) {
    RgbImage image;
    image.width = 37;
    image.height = 11;
    for (int i = 0; i < image.width * image.height * 3; ++i) image.pixels.push_back(std::uint8_t((i * 7) ^ (i >> 3)));
    const fs::path path = fs::temp_directory_path() / "glint-test-png.png";
    save_png(path, image);
    const RgbImage back = load_png(path);
    EXPECT_EQ(back.width, 37);
    EXPECT_EQ(back.height, 11);
    EXPECT_EQ(back.pixels, image.pixels);
    const std::vector<std::uint8_t> bytes = encode_png(image);
    std::ofstream(path, std::ios::binary).write(reinterpret_cast<const char*>(bytes.data()), std::streamsize(bytes.size() - 20));
    EXPECT_THROW(load_png(path), InputError);
    fs::remove(path);
}

TEST(HeadlessDisplay, DrawsReadsBackAndWritesAPng) {
    DisplayConfig config;
    config.kind = "headless";
    config.width = 64;
    config.height = 48;
    std::vector<DisplayAttempt> attempts;
    const std::unique_ptr<gl::Display> display = open_display(config, &attempts);
    ASSERT_EQ(attempts.size(), 1u);
    EXPECT_TRUE(attempts[0].ok);
    EXPECT_EQ(display->kind(), DisplayKind::Headless);
    EXPECT_FALSE(display->degraded());
    display->bind_frame();
    glClearColor(0.2f, 0.4f, 0.6f, 1.0f);
    glClear(GL_COLOR_BUFFER_BIT);
    // The top-left quarter red: rows must come out top first.
    glEnable(GL_SCISSOR_TEST);
    glScissor(0, 24, 32, 24);
    glClearColor(1, 0, 0, 1);
    glClear(GL_COLOR_BUFFER_BIT);
    glDisable(GL_SCISSOR_TEST);
    const RgbImage frame = display->read_frame();
    display->present();
    ASSERT_EQ(frame.width, 64);
    ASSERT_EQ(frame.height, 48);
    EXPECT_EQ(frame.at(0, 0)[0], 255);
    EXPECT_EQ(frame.at(0, 0)[1], 0);
    EXPECT_EQ(frame.at(63, 47)[0], 51);
    EXPECT_EQ(frame.at(63, 47)[1], 102);
    EXPECT_EQ(frame.at(63, 47)[2], 153);
    const fs::path png = fs::temp_directory_path() / "glint-test-headless.png";
    save_png(png, frame);
    EXPECT_EQ(load_png(png).pixels, frame.pixels);
    fs::remove(png);
}

TEST(Displays, AutoWithoutACardOrServerFallsBackToHeadlessAndSaysWhy) {
    // The card is named and does not exist, so the fallback is reached on any machine, with or
    // without a DRM card of its own.
    const char* saved = std::getenv("DISPLAY");
    const std::string keep = saved ? saved : "";
    unsetenv("DISPLAY");
    DisplayConfig config;
    config.card = "/nonexistent/card7";
    config.width = 32;
    config.height = 32;
    std::vector<DisplayAttempt> attempts;
    const std::unique_ptr<gl::Display> display = open_display(config, &attempts);
    if (saved) setenv("DISPLAY", keep.c_str(), 1);
    ASSERT_EQ(attempts.size(), 3u);
    EXPECT_EQ(attempts[0].kind, DisplayKind::Kms);
    EXPECT_FALSE(attempts[0].ok);
    EXPECT_EQ(attempts[0].detail.rfind("/nonexistent/card7: cannot open: ", 0), 0u) << attempts[0].detail;
    EXPECT_EQ(attempts[1].kind, DisplayKind::Window);
    EXPECT_EQ(attempts[1].detail, "no display server ($DISPLAY is not set)");
    EXPECT_TRUE(attempts[2].ok);
    EXPECT_EQ(display->kind(), DisplayKind::Headless);
    EXPECT_TRUE(display->degraded());
}

TEST(Displays, AnExplicitKindFailsWithItsReason) {
    DisplayConfig config;
    config.kind = "kms";
    config.card = "/nonexistent/card9";
    try {
        open_display(config);
        FAIL() << "opened a KMS display on a card that does not exist";
    } catch (const RuntimeError& e) {
        EXPECT_NE(std::string(e.what()).find("kms: /nonexistent/card9: cannot open"), std::string::npos) << e.what();
    }
    config.kind = "television";
    EXPECT_THROW(open_display(config), InputError);
}

// Sends a KeyPress of `key` to the top-level window named `name` on X display `display`.
bool send_key(const std::string& display, const std::string& name, const std::string& key) {
    ::Display* x = XOpenDisplay(display.c_str());
    if (!x) return false;
    Window root = DefaultRootWindow(x), parent = 0, *children = nullptr, target = 0;
    unsigned count = 0;
    if (XQueryTree(x, root, &root, &parent, &children, &count)) {
        for (unsigned i = 0; i < count && !target; ++i) {
            char* title = nullptr;
            if (XFetchName(x, children[i], &title) && title) {
                if (name == title) target = children[i];
                XFree(title);
            }
        }
        if (children) XFree(children);
    }
    bool sent = false;
    if (target) {
        XEvent e{};
        e.xkey.type = KeyPress;
        e.xkey.display = x;
        e.xkey.window = target;
        e.xkey.root = root;
        e.xkey.same_screen = True;
        e.xkey.keycode = XKeysymToKeycode(x, XStringToKeysym(key.c_str()));
        sent = XSendEvent(x, target, True, KeyPressMask, &e) != 0;
        XFlush(x);
    }
    XCloseDisplay(x);
    return sent;
}

// An X server without a screen for the window display. Xvfb is a test dependency
// (scripts/install-deps.sh): its absence fails the test rather than skipping it.
class XvfbServer {
public:
    XvfbServer() {
        for (int n = 91; n < 120 && pid_ <= 0; ++n) {
            if (fs::exists("/tmp/.X11-unix/X" + std::to_string(n)) || fs::exists("/tmp/.X" + std::to_string(n) + "-lock"))
                continue;
            display_ = ":" + std::to_string(n);
            pid_ = fork();
            if (pid_ == 0) {
                execlp("Xvfb", "Xvfb", display_.c_str(), "-screen", "0", "320x240x24", "-nolisten", "tcp", (char*)nullptr);
                _exit(127);
            }
        }
        // Ready when its socket exists.
        for (int i = 0; i < 100 && !fs::exists("/tmp/.X11-unix/X" + display_.substr(1)); ++i) {
            int status = 0;
            if (waitpid(pid_, &status, WNOHANG) == pid_) {
                pid_ = -1;
                break;
            }
            std::this_thread::sleep_for(std::chrono::milliseconds(50));
        }
    }
    ~XvfbServer() {
        if (pid_ > 0) {
            kill(pid_, SIGTERM);
            waitpid(pid_, nullptr, 0);
        }
    }
    bool running() const { return pid_ > 0; }
    const std::string& display() const { return display_; }

private:
    pid_t pid_ = -1;
    std::string display_;
};

TEST(WindowDisplay, UnderXvfbDrawsAScreenshotAndReadsKeys) {
    XvfbServer server;
    ASSERT_TRUE(server.running()) << "Xvfb did not start (install the xvfb package: scripts/install-deps.sh)";
    setenv("DISPLAY", server.display().c_str(), 1);
    DisplayConfig config;
    config.kind = "window";
    config.width = 96;
    config.height = 64;
    std::unique_ptr<gl::Display> display = open_display(config);
    EXPECT_EQ(display->kind(), DisplayKind::Window);
    EXPECT_NE(display->describe().find("window: X display \"" + server.display() + "\""), std::string::npos);
    display->bind_frame();
    glClearColor(0, 1, 0, 1);
    glClear(GL_COLOR_BUFFER_BIT);
    const RgbImage frame = display->read_frame();
    display->present();
    EXPECT_EQ(frame.at(10, 10)[1], 255);
    EXPECT_EQ(frame.at(10, 10)[0], 0);
    // A key through the X server: another client finds the window by its name and sends it a
    // KeyPress, as a keyboard would deliver it.
    ASSERT_TRUE(send_key(server.display(), "Glint", "Escape"));
    std::vector<InputEvent> events;
    for (int i = 0; i < 40 && events.empty(); ++i) {
        events = display->poll_events();
        std::this_thread::sleep_for(std::chrono::milliseconds(25));
    }
    ASSERT_FALSE(events.empty());
    EXPECT_EQ(events[0].type, InputEvent::Type::KeyDown);
    EXPECT_EQ(events[0].key, "Escape");
    // The screenshot a person would see.
    const fs::path png = fs::temp_directory_path() / "glint-test-window.png";
    save_png(png, frame);
    EXPECT_EQ(load_png(png).width, 96);
    fs::remove(png);
    display.reset();
    unsetenv("DISPLAY");
}
