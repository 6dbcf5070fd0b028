// The KMS display's keyboard (evdev_keyboard.hpp).
#include "appliance/gl/evdev_keyboard.hpp"

#include <fcntl.h>
#include <sys/inotify.h>
#include <sys/ioctl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cerrno>
#include <chrono>
#include <cstring>
#include <filesystem>

namespace glint::gl {

const char* evdev_key_name(unsigned code) {
    // Rows of the US layout as evdev numbers them (linux/input-event-codes.h).
    static constexpr const char* kRow1[] = {"1", "2", "3", "4", "5", "6", "7", "8", "9", "0", "minus", "equal"};
    static constexpr const char* kRow2[] = {"q", "w", "e", "r", "t", "y", "u", "i", "o", "p", "bracketleft", "bracketright"};
    static constexpr const char* kRow3[] = {"a", "s", "d", "f", "g", "h", "j", "k", "l", "semicolon", "apostrophe", "grave"};
    static constexpr const char* kRow4[] = {"z", "x", "c", "v", "b", "n", "m", "comma", "period", "slash"};
    // The keypad as with Num Lock on: a numeric keypad is how a technician types a PIN.
    static constexpr const char* kKeypad[] = {"KP_7", "KP_8", "KP_9", "KP_Subtract", "KP_4", "KP_5", "KP_6",
                                              "KP_Add", "KP_1", "KP_2", "KP_3", "KP_0", "KP_Decimal"};
    if (code >= KEY_1 && code <= KEY_EQUAL) return kRow1[code - KEY_1];
    if (code >= KEY_Q && code <= KEY_RIGHTBRACE) return kRow2[code - KEY_Q];
    if (code >= KEY_A && code <= KEY_GRAVE) return kRow3[code - KEY_A];
    if (code >= KEY_Z && code <= KEY_SLASH) return kRow4[code - KEY_Z];
    if (code >= KEY_KP7 && code <= KEY_KPDOT) return kKeypad[code - KEY_KP7];
    if (code >= KEY_F1 && code <= KEY_F10) {
        static constexpr const char* kF[] = {"F1", "F2", "F3", "F4", "F5", "F6", "F7", "F8", "F9", "F10"};
        return kF[code - KEY_F1];
    }
    switch (code) {
        case KEY_ESC: return "Escape";
        case KEY_BACKSPACE: return "BackSpace";
        case KEY_TAB: return "Tab";
        case KEY_ENTER: return "Return";
        case KEY_LEFTCTRL: return "Control_L";
        case KEY_RIGHTCTRL: return "Control_R";
        case KEY_LEFTSHIFT: return "Shift_L";
        case KEY_RIGHTSHIFT: return "Shift_R";
        case KEY_LEFTALT: return "Alt_L";
        case KEY_RIGHTALT: return "Alt_R";
        case KEY_LEFTMETA: return "Super_L";
        case KEY_RIGHTMETA: return "Super_R";
        case KEY_BACKSLASH: return "backslash";
        case KEY_KPASTERISK: return "KP_Multiply";
        case KEY_SPACE: return "space";
        case KEY_F11: return "F11";
        case KEY_F12: return "F12";
        case KEY_KPENTER: return "KP_Enter";
        case KEY_KPSLASH: return "KP_Divide";
        case KEY_HOME: return "Home";
        case KEY_UP: return "Up";
        case KEY_PAGEUP: return "Prior";
        case KEY_LEFT: return "Left";
        case KEY_RIGHT: return "Right";
        case KEY_END: return "End";
        case KEY_DOWN: return "Down";
        case KEY_PAGEDOWN: return "Next";
        case KEY_INSERT: return "Insert";
        case KEY_DELETE: return "Delete";
        default: return nullptr;
    }
}

void KeyDecoder::feed(const input_event& record, std::vector<InputEvent>& out) {
    if (record.type == EV_SYN) {
        if (record.code == SYN_DROPPED) {
            release_all(out);
            dropping_ = true;
        } else if (record.code == SYN_REPORT) {
            dropping_ = false;
        }
        return;
    }
    if (dropping_ || record.type != EV_KEY) return;
    const char* name = evdev_key_name(record.code);
    if (!name) return;
    if (record.value == 0) {
        // A release without its press (held before the grab, or lost in a drop) is not passed on.
        if (held_.erase(record.code) == 0) return;
        out.push_back({InputEvent::Type::KeyUp, name});
    } else if (record.value == 1 || record.value == 2) {
        held_.insert(record.code);
        out.push_back({InputEvent::Type::KeyDown, name});
    }
}

void KeyDecoder::release_all(std::vector<InputEvent>& out) {
    for (const unsigned code : held_) out.push_back({InputEvent::Type::KeyUp, evdev_key_name(code)});
    held_.clear();
}

struct EvdevKeyboards::Device {
    int fd = -1;
    std::string path, describe;
    KeyDecoder decoder;
    std::vector<char> partial;  // a record cut by a pipe's read (a device delivers whole records)
    ~Device() {
        if (fd >= 0) {
            // The grab ends with the descriptor; said explicitly so the order is plain.
            ioctl(fd, EVIOCGRAB, 0);
            ::close(fd);
        }
    }
};

namespace {

bool test_bit(const std::array<unsigned long, (KEY_MAX + 1) / (8 * sizeof(unsigned long)) + 1>& bits, unsigned bit) {
    constexpr unsigned per = 8 * sizeof(unsigned long);
    return (bits[bit / per] >> (bit % per)) & 1UL;
}

bool is_event_node(const std::string& name) {
    return name.rfind("event", 0) == 0 && name.size() > 5 &&
           std::all_of(name.begin() + 5, name.end(), [](char c) { return c >= '0' && c <= '9'; });
}

long long now_ns() {
    return std::chrono::duration_cast<std::chrono::nanoseconds>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

}  // namespace

EvdevKeyboards::EvdevKeyboards(EvdevOptions options, std::function<void(const std::string&)> log)
    : options_(std::move(options)), log_(std::move(log)) {
    inotify_ = inotify_init1(IN_NONBLOCK | IN_CLOEXEC);
    watch();
    std::error_code ec;
    std::vector<std::string> nodes;
    for (const auto& entry : std::filesystem::directory_iterator(options_.dir, ec))
        if (is_event_node(entry.path().filename().string())) nodes.push_back(entry.path().string());
    std::sort(nodes.begin(), nodes.end());
    for (const std::string& node : nodes) open_device(node);
    if (devices_.empty()) log_("keyboard: none in " + options_.dir + " yet (one plugged in later is opened then)");
}

EvdevKeyboards::~EvdevKeyboards() {
    devices_.clear();
    if (inotify_ >= 0) ::close(inotify_);
}

void EvdevKeyboards::watch() {
    if (watching_ || inotify_ < 0) return;
    last_watch_try_ns_ = now_ns();
    // IN_ATTRIB too: udev creates the node first and gives it its group a moment later, so the
    // first open may fail with EACCES and the second succeed. IN_DELETE: the node's name is free
    // for the next device.
    if (inotify_add_watch(inotify_, options_.dir.c_str(), IN_CREATE | IN_ATTRIB | IN_DELETE) >= 0) watching_ = true;
}

void EvdevKeyboards::open_device(const std::string& path) {
    for (const auto& d : devices_)
        if (d->path == path) return;
    if (passed_over_.count(path)) return;
    const int fd = ::open(path.c_str(), O_RDONLY | O_NONBLOCK | O_CLOEXEC);
    if (fd < 0) {
        const int e = errno;
        // Before udev has set the node's group this is expected; IN_ATTRIB brings it back.
        log_("keyboard: " + path + ": cannot open: " + std::strerror(e) +
             (e == EACCES ? " (the unit's SupplementaryGroups= has input)" : ""));
        return;
    }
    std::array<unsigned long, (KEY_MAX + 1) / (8 * sizeof(unsigned long)) + 1> keys{};
    char name[256] = "?";
    if (ioctl(fd, EVIOCGBIT(EV_KEY, sizeof keys), keys.data()) < 0) {
        ::close(fd);
        log_("keyboard: " + path + ": not an evdev device, left alone");
        passed_over_.insert(path);
        return;
    }
    ioctl(fd, EVIOCGNAME(sizeof name - 1), name);
    // A keyboard or a numeric keypad: digits and an Enter. A power button, a mouse or a touch
    // screen is someone else's (logind's power key is the integrator's: docs/lockdown.md).
    const bool digits = test_bit(keys, KEY_1) || test_bit(keys, KEY_KP1);
    const bool enter = test_bit(keys, KEY_ENTER) || test_bit(keys, KEY_KPENTER);
    if (!digits || !enter) {
        ::close(fd);
        log_("keyboard: " + path + " (" + name + "): not a keyboard, left alone");
        passed_over_.insert(path);
        return;
    }
    if (options_.grab && ioctl(fd, EVIOCGRAB, 1) != 0) {
        const int e = errno;
        ::close(fd);
        log_("keyboard: " + path + " (" + name + "): EVIOCGRAB: " + std::strerror(e) +
             (e == EBUSY ? " (another program holds it)" : "") + "; not read, so that no key is shared");
        return;
    }
    auto d = std::make_unique<Device>();
    d->fd = fd;
    d->path = path;
    d->describe = path + " (" + name + (options_.grab ? ", grabbed)" : ", shared)");
    log_("keyboard: " + d->describe);
    devices_.push_back(std::move(d));
}

void EvdevKeyboards::add(int fd, const std::string& name) {
    fcntl(fd, F_SETFL, fcntl(fd, F_GETFL) | O_NONBLOCK);
    auto d = std::make_unique<Device>();
    d->fd = fd;
    d->path = name;
    d->describe = name;
    devices_.push_back(std::move(d));
}

void EvdevKeyboards::hotplug() {
    if (!watching_) {
        // The directory appears with the first input device: look again once a second.
        if (now_ns() - last_watch_try_ns_ < 1'000'000'000LL) return;
        watch();
        if (!watching_) return;
        std::error_code ec;
        for (const auto& entry : std::filesystem::directory_iterator(options_.dir, ec))
            if (is_event_node(entry.path().filename().string())) open_device(entry.path().string());
        return;
    }
    alignas(inotify_event) char buffer[4096];
    for (;;) {
        const ssize_t n = ::read(inotify_, buffer, sizeof buffer);
        if (n <= 0) break;
        for (ssize_t at = 0; at < n;) {
            const auto* e = reinterpret_cast<const inotify_event*>(buffer + at);
            if (e->len > 0 && is_event_node(e->name)) {
                const std::string path = options_.dir + "/" + e->name;
                if (e->mask & IN_DELETE) passed_over_.erase(path);
                else open_device(path);
            }
            if (e->mask & IN_IGNORED) watching_ = false;  // the directory went away
            at += ssize_t(sizeof(inotify_event) + e->len);
        }
    }
}

std::vector<InputEvent> EvdevKeyboards::poll() {
    hotplug();
    std::vector<InputEvent> out;
    for (auto it = devices_.begin(); it != devices_.end();) {
        Device& d = **it;
        bool gone = false;
        for (;;) {
            char buffer[64 * sizeof(input_event)];
            const ssize_t n = ::read(d.fd, buffer, sizeof buffer);
            if (n > 0) {
                d.partial.insert(d.partial.end(), buffer, buffer + n);
                std::size_t at = 0;
                for (; at + sizeof(input_event) <= d.partial.size(); at += sizeof(input_event)) {
                    input_event record;
                    std::memcpy(&record, d.partial.data() + at, sizeof record);
                    d.decoder.feed(record, out);
                }
                d.partial.erase(d.partial.begin(), d.partial.begin() + std::ptrdiff_t(at));
                continue;
            }
            if (n < 0 && errno == EINTR) continue;
            // EAGAIN: nothing more now. ENODEV: unplugged. 0: a pipe's writer closed it.
            gone = n == 0 || (errno != EAGAIN && errno != EWOULDBLOCK);
            break;
        }
        if (gone) {
            d.decoder.release_all(out);
            log_("keyboard: " + d.describe + " gone");
            it = devices_.erase(it);
        } else {
            ++it;
        }
    }
    return out;
}

std::vector<std::string> EvdevKeyboards::devices() const {
    std::vector<std::string> names;
    for (const auto& d : devices_) names.push_back(d->describe);
    return names;
}

}  // namespace glint::gl
