// The KMS display's keyboard (appliance/gl/evdev_keyboard.hpp): records of struct input_event
// written into a pipe, read by the same code that reads /dev/input/event*, decoded into the keys
// the X11 window gives; the maintenance menu's chord fires from them. Hot-plug through inotify.
#include <fcntl.h>
#include <linux/input.h>
#include <unistd.h>

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "appliance/gl/evdev_keyboard.hpp"
#include "appliance/ui/maintenance_menu.hpp"

namespace glint::test {
namespace {

namespace fs = std::filesystem;
using gl::InputEvent;

input_event key(unsigned code, int value) {
    input_event e{};
    e.type = EV_KEY;
    e.code = static_cast<unsigned short>(code);
    e.value = value;
    return e;
}
input_event syn(unsigned code = SYN_REPORT) {
    input_event e{};
    e.type = EV_SYN;
    e.code = static_cast<unsigned short>(code);
    return e;
}

std::string text(const std::vector<InputEvent>& events) {
    std::string s;
    for (const InputEvent& e : events) s += (s.empty() ? "" : " ") + std::string(e.type == InputEvent::Type::KeyDown ? "+" : "-") + e.key;
    return s;
}

// Writes records into a pipe whose read end an EvdevKeyboards reads.
class KeyboardPipe {
public:
    KeyboardPipe(gl::EvdevKeyboards& keyboards, const std::string& name) {
        int fds[2];
        EXPECT_EQ(pipe2(fds, O_CLOEXEC), 0);
        keyboards.add(fds[0], name);
        write_fd_ = fds[1];
    }
    ~KeyboardPipe() { close(); }
    void write(const std::vector<input_event>& records) {
        const auto* bytes = reinterpret_cast<const char*>(records.data());
        EXPECT_EQ(::write(write_fd_, bytes, records.size() * sizeof(input_event)), ssize_t(records.size() * sizeof(input_event)));
    }
    void write_bytes(const void* data, std::size_t n) { EXPECT_EQ(::write(write_fd_, data, n), ssize_t(n)); }
    void close() {
        if (write_fd_ >= 0) ::close(write_fd_);
        write_fd_ = -1;
    }

private:
    int write_fd_ = -1;
};

struct TempDir {
    fs::path path = fs::temp_directory_path() / ("glint-evdev-" + std::to_string(getpid()));
    TempDir() { fs::create_directories(path); }
    ~TempDir() { fs::remove_all(path); }
};

TEST(EvdevKeys, NamesAreTheWindowsKeysyms) {
    EXPECT_STREQ(gl::evdev_key_name(KEY_A), "a");
    EXPECT_STREQ(gl::evdev_key_name(KEY_M), "m");
    EXPECT_STREQ(gl::evdev_key_name(KEY_Z), "z");
    EXPECT_STREQ(gl::evdev_key_name(KEY_1), "1");
    EXPECT_STREQ(gl::evdev_key_name(KEY_0), "0");
    EXPECT_STREQ(gl::evdev_key_name(KEY_F1), "F1");
    EXPECT_STREQ(gl::evdev_key_name(KEY_F10), "F10");
    EXPECT_STREQ(gl::evdev_key_name(KEY_F12), "F12");
    EXPECT_STREQ(gl::evdev_key_name(KEY_ENTER), "Return");
    EXPECT_STREQ(gl::evdev_key_name(KEY_KPENTER), "KP_Enter");
    EXPECT_STREQ(gl::evdev_key_name(KEY_KP0), "KP_0");
    EXPECT_STREQ(gl::evdev_key_name(KEY_KP7), "KP_7");
    EXPECT_STREQ(gl::evdev_key_name(KEY_KPDOT), "KP_Decimal");
    EXPECT_STREQ(gl::evdev_key_name(KEY_ESC), "Escape");
    EXPECT_STREQ(gl::evdev_key_name(KEY_BACKSPACE), "BackSpace");
    EXPECT_STREQ(gl::evdev_key_name(KEY_SPACE), "space");
    EXPECT_STREQ(gl::evdev_key_name(KEY_PAGEUP), "Prior");
    EXPECT_STREQ(gl::evdev_key_name(KEY_PAGEDOWN), "Next");
    EXPECT_STREQ(gl::evdev_key_name(KEY_LEFTCTRL), "Control_L");
    EXPECT_STREQ(gl::evdev_key_name(KEY_RIGHTALT), "Alt_R");
    EXPECT_STREQ(gl::evdev_key_name(KEY_DOT), "period");
    EXPECT_STREQ(gl::evdev_key_name(KEY_MINUS), "minus");
    EXPECT_EQ(gl::evdev_key_name(KEY_POWER), nullptr);
    EXPECT_EQ(gl::evdev_key_name(BTN_LEFT), nullptr);
    // Every letter a-z is named by itself (the chord's key may be any of them).
    const unsigned letters[] = {KEY_A, KEY_B, KEY_C, KEY_D, KEY_E, KEY_F, KEY_G, KEY_H, KEY_I, KEY_J, KEY_K, KEY_L, KEY_M,
                                KEY_N, KEY_O, KEY_P, KEY_Q, KEY_R, KEY_S, KEY_T, KEY_U, KEY_V, KEY_W, KEY_X, KEY_Y, KEY_Z};
    for (int i = 0; i < 26; ++i) EXPECT_EQ(std::string(gl::evdev_key_name(letters[i])), std::string(1, char('a' + i)));
}

TEST(KeyDecoder, PressRepeatRelease) {
    gl::KeyDecoder d;
    std::vector<InputEvent> out;
    for (const input_event& e : {key(KEY_A, 1), syn(), key(KEY_A, 2), syn(), key(KEY_A, 0), syn()}) d.feed(e, out);
    EXPECT_EQ(text(out), "+a +a -a");
}

TEST(KeyDecoder, OtherRecordsAndUnnamedKeysAreIgnored) {
    gl::KeyDecoder d;
    std::vector<InputEvent> out;
    input_event scan{};
    scan.type = EV_MSC;
    scan.code = MSC_SCAN;
    scan.value = 0x1e;
    input_event led{};
    led.type = EV_LED;
    for (const input_event& e : {scan, led, key(KEY_POWER, 1), key(KEY_POWER, 0), key(BTN_LEFT, 1), syn()}) d.feed(e, out);
    EXPECT_TRUE(out.empty()) << text(out);
}

TEST(KeyDecoder, AReleaseWithoutItsPressIsDropped) {
    // Enter still held from the shell that started the kiosk: its release arrives after the grab.
    gl::KeyDecoder d;
    std::vector<InputEvent> out;
    d.feed(key(KEY_ENTER, 0), out);
    EXPECT_TRUE(out.empty());
}

TEST(KeyDecoder, DroppedRecordsReleaseEverythingHeld) {
    gl::KeyDecoder d;
    std::vector<InputEvent> out;
    for (const input_event& e : {key(KEY_LEFTCTRL, 1), key(KEY_LEFTALT, 1), syn()}) d.feed(e, out);
    out.clear();
    // The kernel's buffer overran: nothing until the next report is trusted.
    for (const input_event& e : {syn(SYN_DROPPED), key(KEY_M, 1), syn(), key(KEY_B, 1), syn()}) d.feed(e, out);
    EXPECT_EQ(text(out), "-Control_L -Alt_L +b");
}

TEST(EvdevKeyboards, ThePipeDeliversKeysAndTheChordFires) {
    std::vector<std::string> log;
    TempDir dir;
    gl::EvdevKeyboards keyboards({dir.path.string(), true}, [&](const std::string& l) { log.push_back(l); });
    KeyboardPipe pipe(keyboards, "pipe");
    ui::MenuChord chord("ctrl+alt+m");
    pipe.write({key(KEY_LEFTCTRL, 1), syn(), key(KEY_RIGHTALT, 1), syn()});
    std::vector<InputEvent> events = keyboards.poll();
    EXPECT_EQ(text(events), "+Control_L +Alt_R");
    EXPECT_FALSE(chord.feed(events));
    pipe.write({key(KEY_M, 1), syn(), key(KEY_M, 0), syn()});
    events = keyboards.poll();
    EXPECT_EQ(text(events), "+m -m");
    EXPECT_TRUE(chord.feed(events));
    // m alone after the modifiers are let go does not.
    pipe.write({key(KEY_LEFTCTRL, 0), key(KEY_RIGHTALT, 0), syn(), key(KEY_M, 1), key(KEY_M, 0), syn()});
    EXPECT_FALSE(chord.feed(keyboards.poll()));
    // A chord on a function key, as the config allows.
    ui::MenuChord f_chord("ctrl+shift+f9");
    pipe.write({key(KEY_RIGHTCTRL, 1), key(KEY_LEFTSHIFT, 1), key(KEY_F9, 1), syn()});
    EXPECT_TRUE(f_chord.feed(keyboards.poll()));
}

TEST(EvdevKeyboards, APinTypedOnTheKeypadGivesTheMenusKeys) {
    TempDir dir;
    gl::EvdevKeyboards keyboards({dir.path.string(), true}, [](const std::string&) {});
    KeyboardPipe pipe(keyboards, "keypad");
    std::vector<input_event> records;
    for (const unsigned code : {KEY_KP4, KEY_KP2, KEY_7, KEY_BACKSPACE, KEY_KP1, KEY_KPENTER}) {
        records.push_back(key(code, 1));
        records.push_back(key(code, 0));
        records.push_back(syn());
    }
    pipe.write(records);
    std::vector<std::string> downs;
    for (const InputEvent& e : keyboards.poll())
        if (e.type == InputEvent::Type::KeyDown) downs.push_back(e.key);
    // The PIN page takes digits ("7", "KP_4"), BackSpace and Return or KP_Enter.
    EXPECT_EQ(downs, (std::vector<std::string>{"KP_4", "KP_2", "7", "BackSpace", "KP_1", "KP_Enter"}));
}

TEST(EvdevKeyboards, ARecordSplitAcrossReadsIsJoined) {
    TempDir dir;
    gl::EvdevKeyboards keyboards({dir.path.string(), true}, [](const std::string&) {});
    KeyboardPipe pipe(keyboards, "pipe");
    const input_event e = key(KEY_Q, 1);
    const auto* bytes = reinterpret_cast<const char*>(&e);
    pipe.write_bytes(bytes, 5);
    EXPECT_TRUE(keyboards.poll().empty());
    pipe.write_bytes(bytes + 5, sizeof e - 5);
    EXPECT_EQ(text(keyboards.poll()), "+q");
}

TEST(EvdevKeyboards, AKeyboardGoneReleasesItsKeys) {
    std::vector<std::string> log;
    TempDir dir;
    gl::EvdevKeyboards keyboards({dir.path.string(), true}, [&](const std::string& l) { log.push_back(l); });
    KeyboardPipe pipe(keyboards, "usb-keyboard");
    pipe.write({key(KEY_LEFTSHIFT, 1), syn()});
    EXPECT_EQ(text(keyboards.poll()), "+Shift_L");
    EXPECT_EQ(keyboards.devices(), (std::vector<std::string>{"usb-keyboard"}));
    pipe.close();  // unplugged
    EXPECT_EQ(text(keyboards.poll()), "-Shift_L");
    EXPECT_TRUE(keyboards.devices().empty());
    ASSERT_FALSE(log.empty());
    EXPECT_EQ(log.back(), "keyboard: usb-keyboard gone");
}

TEST(EvdevKeyboards, TwoKeyboardsAreBothRead) {
    TempDir dir;
    gl::EvdevKeyboards keyboards({dir.path.string(), true}, [](const std::string&) {});
    KeyboardPipe a(keyboards, "a"), b(keyboards, "b");
    a.write({key(KEY_LEFTCTRL, 1), syn()});
    b.write({key(KEY_X, 1), syn()});
    EXPECT_EQ(text(keyboards.poll()), "+Control_L +x");
}

// What is not an evdev device in the directory is passed over, and a node that appears later is
// looked at on the next poll (inotify), so a keyboard plugged in while the kiosk runs is opened.
TEST(EvdevKeyboards, NodesAppearingLaterAreLookedAt) {
    std::vector<std::string> log;
    TempDir dir;
    std::ofstream(dir.path / "event0") << "not a device";
    std::ofstream(dir.path / "mouse0") << "not an event node";
    gl::EvdevKeyboards keyboards({dir.path.string(), true}, [&](const std::string& l) { log.push_back(l); });
    EXPECT_EQ(log, (std::vector<std::string>{"keyboard: " + (dir.path / "event0").string() + ": not an evdev device, left alone",
                                             "keyboard: none in " + dir.path.string() +
                                                 " yet (one plugged in later is opened then)"}));
    log.clear();
    EXPECT_TRUE(keyboards.poll().empty());
    EXPECT_TRUE(log.empty());
    std::ofstream(dir.path / "event7") << "plugged in";
    keyboards.poll();
    const std::string passed_over = "keyboard: " + (dir.path / "event7").string() + ": not an evdev device, left alone";
    EXPECT_EQ(log, (std::vector<std::string>{passed_over}));
    // An attribute change (udev setting the group) does not bring it up again...
    fs::permissions(dir.path / "event7", fs::perms::owner_read | fs::perms::group_read);
    keyboards.poll();
    EXPECT_EQ(log.size(), 1u);
    // ... a new node under the same name (event numbers are reused) does.
    fs::remove(dir.path / "event7");
    std::ofstream(dir.path / "event7") << "another device";
    keyboards.poll();
    EXPECT_EQ(log, (std::vector<std::string>{passed_over, passed_over}));
}

TEST(EvdevKeyboards, ANodeThatCannotBeOpenedIsNamed) {
    // A node gone between its creation and the open (a dangling link stands in for it: root may
    // open any file whatever its mode, so EACCES cannot be made here).
    std::vector<std::string> log;
    TempDir dir;
    gl::EvdevKeyboards keyboards({dir.path.string(), true}, [&](const std::string& l) { log.push_back(l); });
    log.clear();
    fs::create_symlink(dir.path / "nowhere", dir.path / "event3");
    keyboards.poll();
    ASSERT_FALSE(log.empty());
    EXPECT_EQ(log.front(), "keyboard: " + (dir.path / "event3").string() + ": cannot open: No such file or directory");
}

}  // namespace
}  // namespace glint::test
