// The KMS display's keyboard (docs/lockdown.md): Linux evdev devices read directly, without a
// display server. Each keyboard is grabbed (EVIOCGRAB): while the kiosk holds it, its keys reach
// no other reader, not the console's keyboard handler (so no Ctrl+Alt+Del, no Alt+F2, no SysRq),
// not logind. Keys become the same InputEvents the X11 window gives (display.hpp: X11 keysym names
// of a US layout), so the maintenance menu's chord and PIN work alike on both.
//
// Two parts, each with one job: KeyDecoder turns struct input_event records into key events;
// EvdevKeyboards finds, opens, grabs and reads the devices (hot-plug through inotify). Any
// descriptor delivering input_event records can be added, which is how the tests feed it (a pipe).
#pragma once

#include <linux/input.h>

#include <functional>
#include <memory>
#include <set>
#include <string>
#include <vector>

#include "appliance/gl/input_event.hpp"

namespace glint::gl {

// The X11 keysym name (XLookupKeysym index 0, US layout) of an evdev key code: "a", "1", "F1",
// "Return", "KP_Enter", "Control_L", ...; nullptr for codes the kiosk has no use for.
const char* evdev_key_name(unsigned code);

// One device's records in, key events out. Autorepeat (value 2) is a KeyDown again, as X11 gives
// it. After SYN_DROPPED (the kernel's buffer overran) every key held is released and the records
// up to the next SYN_REPORT are dropped, so no modifier stays stuck down.
class KeyDecoder {
public:
    void feed(const input_event& record, std::vector<InputEvent>& out);
    // Releases whatever is held (the device went away).
    void release_all(std::vector<InputEvent>& out);

private:
    std::set<unsigned> held_;
    bool dropping_ = false;
};

struct EvdevOptions {
    std::string dir = "/dev/input";  // where event* device nodes appear
    bool grab = true;                // EVIOCGRAB each keyboard; one that cannot be grabbed is not read
};

class EvdevKeyboards {
public:
    // Opens every keyboard in options.dir now and watches it for more. `log` gets one line per
    // device opened, refused or gone.
    EvdevKeyboards(EvdevOptions options, std::function<void(const std::string&)> log);
    ~EvdevKeyboards();
    EvdevKeyboards(const EvdevKeyboards&) = delete;
    EvdevKeyboards& operator=(const EvdevKeyboards&) = delete;

    // Reads `fd` (taken over; non-blocking) as a keyboard named `name`: a device already checked,
    // or a pipe of input_event records.
    void add(int fd, const std::string& name);
    // Keys since the last call, from every keyboard, without waiting; devices plugged in since are
    // opened first, those unplugged are closed (their held keys released).
    std::vector<InputEvent> poll();
    // "/dev/input/event3 (AT Translated Set 2 keyboard, grabbed)" per keyboard read.
    std::vector<std::string> devices() const;

private:
    struct Device;
    void open_device(const std::string& path);
    void watch();
    void hotplug();

    EvdevOptions options_;
    std::function<void(const std::string&)> log_;
    std::vector<std::unique_ptr<Device>> devices_;
    // Nodes found not to be keyboards: not looked at again on each attribute change, until the
    // node is deleted (event numbers are reused by the next device plugged in).
    std::set<std::string> passed_over_;
    int inotify_ = -1;
    bool watching_ = false;
    long long last_watch_try_ns_ = 0;
};

}  // namespace glint::gl
