// Debouncing of one push button sampled by the main loop: a new level is accepted once it has
// been read without interruption for the debounce time. Contact bounce (a few ms of toggling
// on each edge) never produces more than one edge.
#pragma once

#include <cstdint>

namespace glint::firmware {

class ButtonDebouncer {
public:
    struct Edge {
        bool happened = false;
        bool pressed = false;
        std::uint64_t timestamp_us = 0;  // board clock when the new level was first read
    };

    // `pressed` is the raw level read at `now_us` (board clock). Returns the debounced edge, if
    // this sample completed one.
    Edge sample(bool pressed, std::uint64_t now_us, std::uint32_t debounce_us) {
        Edge edge;
        if (pressed != candidate_) {
            candidate_ = pressed;
            candidate_since_us_ = now_us;
        }
        if (candidate_ != stable_ && now_us - candidate_since_us_ >= debounce_us) {
            stable_ = candidate_;
            edge = {true, stable_, candidate_since_us_};
        }
        return edge;
    }
    bool pressed() const { return stable_; }

private:
    bool stable_ = false;     // debounced level (released at start)
    bool candidate_ = false;  // last raw level
    std::uint64_t candidate_since_us_ = 0;
};

}  // namespace glint::firmware
