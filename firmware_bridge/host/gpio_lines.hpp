// GPIO buttons and lamps on the appliance (the kiosk's visitor buttons, the status lamps).
//
// GpioChip is the hardware boundary, with two backends: LibgpiodChip (libgpiod 1.6's C++ API,
// as Debian 12 ships it: edge events with kernel timestamps, output lines) and FakeGpioChip (tests:
// the test injects edges with times and reads the outputs). On top, hardware-independent:
// - Debouncer: an edge starts a burst; the burst ends when the line has been quiet for the
//   window (20 ms by default); if the level then differs from the debounced one, that is one
//   press or release, stamped with the time of the burst's FIRST edge (when the contact
//   actually closed). A glitch shorter than the window that returns to the old level is nothing.
// - ButtonService: a thread (or poll() on a virtual clock) reading edges, debouncing them, and
//   handing out press/release events; optionally recording every raw edge (Recorder::on_gpio).
// - LampDriver: per output line a pattern (off, on, blink, a sequence of steps), evaluated
//   against a clock: update(now) sets each line to the pattern's level at `now`.
// Times are appliance CLOCK_MONOTONIC ns (libgpiod 1.6 event timestamps are CLOCK_MONOTONIC on
// Linux 5.7 and later; Debian 12 runs 6.1).
#pragma once

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include "firmware_bridge/recording/clock.hpp"
#include "firmware_bridge/recording/recorder.hpp"

namespace gpiod {
class chip;
class line_bulk;
}  // namespace gpiod

namespace glint::host {

class GpioError : public std::runtime_error {
    using std::runtime_error::runtime_error;
};

struct GpioEdge {
    unsigned line = 0;
    bool high = false;     // the level after the edge (already inverted for active-low inputs)
    std::int64_t t_ns = 0;
};

class GpioChip {
public:
    virtual ~GpioChip() = default;
    virtual std::string name() const = 0;
    // Inputs report both edges; active_low inverts their levels (a button to ground reads high
    // when pressed). Throws GpioError naming the chip and line.
    virtual void request_inputs(const std::vector<unsigned>& lines, bool active_low) = 0;
    virtual void request_outputs(const std::vector<unsigned>& lines) = 0;
    // The next edge on any input, waiting up to `timeout`; nullopt when none came.
    virtual std::optional<GpioEdge> wait_edge(std::chrono::milliseconds timeout) = 0;
    virtual void set_output(unsigned line, bool high) = 0;
};

// libgpiod 1.6 (gpiod.hpp). Opening a chip that is not there throws GpioError naming it.
class LibgpiodChip final : public GpioChip {
public:
    explicit LibgpiodChip(const std::string& path_or_name, std::string consumer = "glint");
    ~LibgpiodChip() override;
    std::string name() const override { return name_; }
    void request_inputs(const std::vector<unsigned>& lines, bool active_low) override;
    void request_outputs(const std::vector<unsigned>& lines) override;
    std::optional<GpioEdge> wait_edge(std::chrono::milliseconds timeout) override;
    void set_output(unsigned line, bool high) override;

private:
    std::string name_, consumer_;
    std::unique_ptr<gpiod::chip> chip_;
    std::unique_ptr<gpiod::line_bulk> inputs_;
    std::map<unsigned, std::unique_ptr<gpiod::line_bulk>> outputs_;
};

// Tests' chip: inject() queues an edge; outputs keep their level and every change with its time.
class FakeGpioChip final : public GpioChip {
public:
    explicit FakeGpioChip(recording::Clock& clock, std::string name = "fake-gpiochip") : clock_(clock), name_(std::move(name)) {}
    std::string name() const override { return name_; }
    void request_inputs(const std::vector<unsigned>& lines, bool active_low) override;
    void request_outputs(const std::vector<unsigned>& lines) override;
    std::optional<GpioEdge> wait_edge(std::chrono::milliseconds timeout) override;
    void set_output(unsigned line, bool high) override;

    void inject(unsigned line, bool high, std::int64_t t_ns);  // a raw edge (before active-low)
    bool output(unsigned line) const;
    std::vector<std::pair<std::int64_t, bool>> output_changes(unsigned line) const;

private:
    recording::Clock& clock_;
    std::string name_;
    mutable std::mutex mutex_;
    std::condition_variable cv_;
    std::deque<GpioEdge> edges_;
    std::map<unsigned, bool> inputs_;  // line -> active_low
    std::map<unsigned, std::vector<std::pair<std::int64_t, bool>>> outputs_;
};

struct ButtonEvent {
    unsigned line = 0;
    bool pressed = false;
    std::int64_t t_ns = 0;  // when the contact closed or opened (the burst's first edge)
};

class Debouncer {
public:
    explicit Debouncer(std::int64_t window_ns = 20'000'000) : window_ns_(window_ns) {}
    void feed(const GpioEdge& edge);
    // Ends the bursts quiet since `now_ns` - window; returns the changes, in time order.
    std::vector<ButtonEvent> poll(std::int64_t now_ns);

private:
    struct Line {
        bool debounced = false, raw = false, in_burst = false;
        std::int64_t burst_start = 0, last_edge = 0;
    };
    std::int64_t window_ns_;
    std::map<unsigned, Line> lines_;
    std::vector<ButtonEvent> pending_;  // bursts ended inside a batch of edges
};

class ButtonService {
public:
    ButtonService(GpioChip& chip, std::vector<unsigned> lines, bool active_low, recording::Clock& clock,
                  std::int64_t debounce_ns = 20'000'000);
    ~ButtonService();
    void set_recorder(recording::Recorder* recorder) { recorder_ = recorder; }
    // Called on the service's thread for every debounced press and release.
    void set_callback(std::function<void(const ButtonEvent&)> callback) { callback_ = std::move(callback); }
    void start();  // a thread waiting for edges
    void stop();
    // One step on the calling thread: takes the edges waiting (up to `wait`), debounces, calls back.
    void poll(std::chrono::milliseconds wait = std::chrono::milliseconds(0));

private:
    GpioChip& chip_;
    recording::Clock& clock_;
    Debouncer debouncer_;
    recording::Recorder* recorder_ = nullptr;
    std::function<void(const ButtonEvent&)> callback_;
    std::thread thread_;
    std::atomic<bool> stopping_{false};
};

struct LampPattern {
    enum class Kind { Off, On, Blink, Sequence } kind = Kind::Off;
    std::int64_t period_ns = 1'000'000'000;  // Blink
    double duty = 0.5;                        // Blink: share of the period the lamp is on
    std::vector<std::pair<bool, std::int64_t>> steps;  // Sequence: (level, duration ns), repeated
    static LampPattern off() { return {}; }
    static LampPattern on() { return {Kind::On, 0, 0, {}}; }
    static LampPattern blink(std::int64_t period_ns, double duty = 0.5) { return {Kind::Blink, period_ns, duty, {}}; }
    static LampPattern sequence(std::vector<std::pair<bool, std::int64_t>> steps) {
        return {Kind::Sequence, 0, 0, std::move(steps)};
    }
    // The level `elapsed_ns` after the pattern started.
    bool level_at(std::int64_t elapsed_ns) const;
};

class LampDriver {
public:
    LampDriver(GpioChip& chip, std::vector<unsigned> lines, recording::Clock& clock);
    ~LampDriver();
    // Starts `pattern` on `line` now (its phase starts at this call).
    void set_pattern(unsigned line, LampPattern pattern);
    // Sets every line to its pattern's level at the clock's now (writes only changes).
    void update();
    void start(std::chrono::milliseconds tick = std::chrono::milliseconds(5));  // update() on a thread
    void stop();

private:
    struct State {
        LampPattern pattern;
        std::int64_t start_ns = 0;
        std::optional<bool> written;
    };
    GpioChip& chip_;
    recording::Clock& clock_;
    std::mutex mutex_;
    std::map<unsigned, State> lines_;
    std::thread thread_;
    std::atomic<bool> stopping_{false};
};

}  // namespace glint::host
