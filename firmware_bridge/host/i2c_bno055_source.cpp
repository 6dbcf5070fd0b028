#include "firmware_bridge/host/i2c_bno055_source.hpp"

#include <cstdio>

namespace glint::host {

namespace {
std::string address_text(std::uint8_t a) {
    char b[8];
    std::snprintf(b, sizeof b, "0x%02x", a);
    return b;
}
firmware::Bno055Config driver_config(const I2cBno055Options& o) {
    firmware::Bno055Config c;
    c.address = o.address;
    return c;
}
}  // namespace

I2cBno055Source::I2cBno055Source(std::string name, firmware::I2cBus& bus, I2cBno055Options options,
                                 recording::Clock& clock, SourceOptions source_options)
    : OrientationSource(std::move(name), clock, source_options),
      bus_(bus),
      options_(std::move(options)),
      driver_(bus_, driver_config(options_)) {
    if (options_.address != 0x28 && options_.address != 0x29)
        throw SourceError(this->name() + ": I2C address " + address_text(options_.address) +
                          " is not a BNO055's (0x28 or 0x29)");
    if (options_.rate_hz < 1 || options_.rate_hz > 100)
        throw SourceError(this->name() + ": rate " + std::to_string(options_.rate_hz) + " Hz is outside 1..100");
}

I2cBno055Source::~I2cBno055Source() { stop(); }

void I2cBno055Source::poll_once() {
    const std::uint64_t now = clock().now_us();
    firmware::ImuReading reading;
    const firmware::ImuStatus status = driver_.poll(now, reading);
    const bool running = driver_.state() == firmware::Bno055Imu::State::Running;
    switch (status) {
        case firmware::ImuStatus::Ok:
        case firmware::ImuStatus::Degraded:
            if (reading.has_orientation) {
                OrientationSample s;
                s.t_ns = std::int64_t(now) * 1000;
                s.world_from_sensor = to_glm(firmware::quat_cast<double>(reading.world_from_sensor));
                publish(s);
            }
            break;
        case firmware::ImuStatus::Starting:
            break;
        case firmware::ImuStatus::ReadFailed:
        case firmware::ImuStatus::NotResponding: {
            std::string why = options_.bus_error ? options_.bus_error() : std::string();
            note_error(name() + ": BNO055 at " + address_text(options_.address) +
                       (status == firmware::ImuStatus::ReadFailed ? " stopped answering" : " does not answer") +
                       (why.empty() ? "" : " (" + why + ")"));
            edit_health([](LinkHealth& h) { ++h.timeouts; });
            set_state(LinkState::Disconnected);
            break;
        }
    }
    if (running && !was_running_) {
        // Running again: the first time is the start; every later time the chip was lost first.
        if (probes_at_running_ > 0) edit_health([](LinkHealth& h) { ++h.reconnects; });
        probes_at_running_ = driver_.probes();
        if (health().state == LinkState::Disconnected) set_state(LinkState::Connecting);
    }
    was_running_ = running;
    check_stall();
}

void I2cBno055Source::run_until(std::uint64_t end_us) {
    if (health().state == LinkState::Stopped) set_state(LinkState::Connecting);
    const std::uint64_t period = 1'000'000 / std::uint64_t(options_.rate_hz);
    if (next_us_ == 0) next_us_ = clock().now_us();
    while (!stopping_ && clock().now_us() < end_us) {
        poll_once();
        next_us_ += period;
        const std::uint64_t now = clock().now_us();
        if (next_us_ < now) next_us_ = now;  // fell behind (a slow bus): no burst of catch-up polls
        clock().sleep_until_us(std::min(next_us_, end_us));
    }
}

void I2cBno055Source::start() {
    if (thread_.joinable()) return;
    stopping_ = false;
    set_state(LinkState::Connecting);
    thread_ = std::thread([this] { run_until(UINT64_MAX); });
}

void I2cBno055Source::stop() {
    stopping_ = true;
    if (thread_.joinable()) thread_.join();
    set_state(LinkState::Stopped);
}

namespace {
I2cBno055Options linux_options(std::uint8_t address, const LinuxI2cBus& bus) {
    I2cBno055Options o;
    o.address = address;
    o.bus_error = [&bus] { return bus.last_error(); };
    return o;
}
}  // namespace

LinuxBno055Source::LinuxBno055Source(std::string name, std::string device, std::uint8_t address,
                                     recording::Clock& clock, SourceOptions source_options)
    : detail::LinuxI2cBusHolder(std::move(device)),
      I2cBno055Source(std::move(name), linux_bus, linux_options(address, linux_bus), clock, source_options) {}

}  // namespace glint::host
