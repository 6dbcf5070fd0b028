// A key from the window or the KMS display's evdev keyboards, or replayed (display.hpp). Apart
// from display.hpp so that the evdev keyboards (evdev_keyboard.hpp) need no GL headers.
#pragma once

#include <string>

namespace glint::gl {

// Keys are X11 keysym names ("Escape", "space", "Return", "m", "F1"), whichever display gave them.
struct InputEvent {
    enum class Type { KeyDown, KeyUp, Quit } type = Type::KeyDown;
    std::string key;
};

}  // namespace glint::gl
