#include "firmware_bridge/host/gpio_lines.hpp"

#include <gpiod.hpp>

#include <algorithm>
#include <system_error>

namespace glint::host {

// ---- LibgpiodChip ----

LibgpiodChip::LibgpiodChip(const std::string& path_or_name, std::string consumer)
    : name_(path_or_name), consumer_(std::move(consumer)) {
    try {
        chip_ = std::make_unique<gpiod::chip>(path_or_name, gpiod::chip::OPEN_LOOKUP);
    } catch (const std::exception& e) {
        throw GpioError("GPIO chip " + path_or_name + ": cannot open: " + e.what());
    }
    if (!*chip_) throw GpioError("GPIO chip " + path_or_name + ": not found");
}

LibgpiodChip::~LibgpiodChip() = default;

void LibgpiodChip::request_inputs(const std::vector<unsigned>& lines, bool active_low) {
    try {
        inputs_ = std::make_unique<gpiod::line_bulk>(chip_->get_lines(lines));
        gpiod::line_request r{consumer_, gpiod::line_request::EVENT_BOTH_EDGES, {}};
        if (active_low) r.flags = gpiod::line_request::FLAG_ACTIVE_LOW;
        inputs_->request(r);
    } catch (const std::exception& e) {
        throw GpioError("GPIO chip " + name_ + ": cannot request input lines: " + e.what());
    }
}

void LibgpiodChip::request_outputs(const std::vector<unsigned>& lines) {
    for (unsigned l : lines) {
        try {
            auto bulk = std::make_unique<gpiod::line_bulk>(chip_->get_lines({l}));
            bulk->request({consumer_, gpiod::line_request::DIRECTION_OUTPUT, {}}, {0});
            outputs_[l] = std::move(bulk);
        } catch (const std::exception& e) {
            throw GpioError("GPIO chip " + name_ + ": cannot request output line " + std::to_string(l) + ": " + e.what());
        }
    }
}

std::optional<GpioEdge> LibgpiodChip::wait_edge(std::chrono::milliseconds timeout) {
    if (!inputs_) return std::nullopt;
    gpiod::line_bulk ready = inputs_->event_wait(std::chrono::duration_cast<std::chrono::nanoseconds>(timeout));
    if (!ready) return std::nullopt;
    const gpiod::line_event ev = ready.get(0).event_read();
    return GpioEdge{ev.source.offset(), ev.event_type == gpiod::line_event::RISING_EDGE, ev.timestamp.count()};
}

void LibgpiodChip::set_output(unsigned line, bool high) {
    const auto it = outputs_.find(line);
    if (it == outputs_.end()) throw GpioError("GPIO chip " + name_ + ": line " + std::to_string(line) + " is not an output");
    it->second->set_values({high ? 1 : 0});
}

// ---- FakeGpioChip ----

void FakeGpioChip::request_inputs(const std::vector<unsigned>& lines, bool active_low) {
    const std::lock_guard lock(mutex_);
    for (unsigned l : lines) inputs_[l] = active_low;
}

void FakeGpioChip::request_outputs(const std::vector<unsigned>& lines) {
    const std::lock_guard lock(mutex_);
    for (unsigned l : lines) outputs_[l] = {};
}

void FakeGpioChip::inject(unsigned line, bool high, std::int64_t t_ns) {
    {
        const std::lock_guard lock(mutex_);
        const auto it = inputs_.find(line);
        if (it == inputs_.end()) throw GpioError(name_ + ": line " + std::to_string(line) + " was not requested as input");
        edges_.push_back({line, it->second ? !high : high, t_ns});
    }
    cv_.notify_one();
}

std::optional<GpioEdge> FakeGpioChip::wait_edge(std::chrono::milliseconds timeout) {
    std::unique_lock lock(mutex_);
    if (edges_.empty()) {
        // On a virtual clock nobody else moves time: an empty queue is an immediate timeout.
        if (!cv_.wait_for(lock, timeout, [&] { return !edges_.empty(); })) return std::nullopt;
    }
    const GpioEdge e = edges_.front();
    edges_.pop_front();
    return e;
}

void FakeGpioChip::set_output(unsigned line, bool high) {
    const std::int64_t t = std::int64_t(clock_.now_us()) * 1000;
    const std::lock_guard lock(mutex_);
    const auto it = outputs_.find(line);
    if (it == outputs_.end()) throw GpioError(name_ + ": line " + std::to_string(line) + " is not an output");
    it->second.emplace_back(t, high);
}

bool FakeGpioChip::output(unsigned line) const {
    const std::lock_guard lock(mutex_);
    const auto it = outputs_.find(line);
    return it != outputs_.end() && !it->second.empty() && it->second.back().second;
}

std::vector<std::pair<std::int64_t, bool>> FakeGpioChip::output_changes(unsigned line) const {
    const std::lock_guard lock(mutex_);
    const auto it = outputs_.find(line);
    return it == outputs_.end() ? std::vector<std::pair<std::int64_t, bool>>{} : it->second;
}

// ---- Debouncer ----

void Debouncer::feed(const GpioEdge& e) {
    Line& l = lines_[e.line];
    // Edges may arrive in a batch: a quiet gap of a whole window inside the batch ends the
    // burst before it, as poll() would have at the time.
    if (l.in_burst && e.t_ns - l.last_edge >= window_ns_) {
        l.in_burst = false;
        if (l.raw != l.debounced) {
            l.debounced = l.raw;
            pending_.push_back({e.line, l.raw, l.burst_start});
        }
    }
    if (!l.in_burst) {
        l.in_burst = true;
        l.burst_start = e.t_ns;
    }
    l.raw = e.high;
    l.last_edge = e.t_ns;
}

std::vector<ButtonEvent> Debouncer::poll(std::int64_t now_ns) {
    std::vector<ButtonEvent> out;
    out.swap(pending_);
    for (auto& [line, l] : lines_) {
        if (!l.in_burst || now_ns - l.last_edge < window_ns_) continue;
        l.in_burst = false;
        if (l.raw != l.debounced) {
            l.debounced = l.raw;
            out.push_back({line, l.raw, l.burst_start});
        }
    }
    std::sort(out.begin(), out.end(), [](const ButtonEvent& a, const ButtonEvent& b) { return a.t_ns < b.t_ns; });
    return out;
}

// ---- ButtonService ----

ButtonService::ButtonService(GpioChip& chip, std::vector<unsigned> lines, bool active_low, recording::Clock& clock,
                             std::int64_t debounce_ns)
    : chip_(chip), clock_(clock), debouncer_(debounce_ns) {
    chip_.request_inputs(lines, active_low);
}

ButtonService::~ButtonService() { stop(); }

void ButtonService::poll(std::chrono::milliseconds wait) {
    for (std::optional<GpioEdge> e = chip_.wait_edge(wait); e; e = chip_.wait_edge(std::chrono::milliseconds(0))) {
        if (recorder_)
            recorder_->on_gpio(std::uint64_t(e->t_ns / 1000), e->line,
                               e->high ? recording::Edge::Rising : recording::Edge::Falling, chip_.name());
        debouncer_.feed(*e);
    }
    for (const ButtonEvent& b : debouncer_.poll(std::int64_t(clock_.now_us()) * 1000))
        if (callback_) callback_(b);
}

void ButtonService::start() {
    if (thread_.joinable()) return;
    stopping_ = false;
    thread_ = std::thread([this] {
        while (!stopping_) poll(std::chrono::milliseconds(5));
    });
}

void ButtonService::stop() {
    stopping_ = true;
    if (thread_.joinable()) thread_.join();
}

// ---- Lamps ----

bool LampPattern::level_at(std::int64_t t) const {
    switch (kind) {
        case Kind::Off: return false;
        case Kind::On: return true;
        case Kind::Blink: {
            if (period_ns <= 0) return false;
            const std::int64_t phase = ((t % period_ns) + period_ns) % period_ns;
            return double(phase) < duty * double(period_ns);
        }
        case Kind::Sequence: {
            std::int64_t total = 0;
            for (const auto& s : steps) total += std::max<std::int64_t>(0, s.second);
            if (total <= 0) return false;
            std::int64_t phase = ((t % total) + total) % total;
            for (const auto& [level, duration] : steps) {
                if (phase < duration) return level;
                phase -= std::max<std::int64_t>(0, duration);
            }
            return false;
        }
    }
    return false;
}

LampDriver::LampDriver(GpioChip& chip, std::vector<unsigned> lines, recording::Clock& clock) : chip_(chip), clock_(clock) {
    chip_.request_outputs(lines);
    for (unsigned l : lines) lines_[l] = {};
}

LampDriver::~LampDriver() { stop(); }

void LampDriver::set_pattern(unsigned line, LampPattern pattern) {
    const std::lock_guard lock(mutex_);
    const auto it = lines_.find(line);
    if (it == lines_.end()) throw GpioError(chip_.name() + ": line " + std::to_string(line) + " is not a lamp");
    it->second.pattern = std::move(pattern);
    it->second.start_ns = std::int64_t(clock_.now_us()) * 1000;
}

void LampDriver::update() {
    const std::int64_t now = std::int64_t(clock_.now_us()) * 1000;
    const std::lock_guard lock(mutex_);
    for (auto& [line, s] : lines_) {
        const bool level = s.pattern.level_at(now - s.start_ns);
        if (s.written && *s.written == level) continue;
        chip_.set_output(line, level);
        s.written = level;
    }
}

void LampDriver::start(std::chrono::milliseconds tick) {
    if (thread_.joinable()) return;
    stopping_ = false;
    thread_ = std::thread([this, tick] {
        while (!stopping_) {
            update();
            std::this_thread::sleep_for(tick);
        }
    });
}

void LampDriver::stop() {
    stopping_ = true;
    if (thread_.joinable()) thread_.join();
}

}  // namespace glint::host
