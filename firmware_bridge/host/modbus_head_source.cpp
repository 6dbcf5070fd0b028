#include "firmware_bridge/host/modbus_head_source.hpp"

#include <modbus/modbus.h>

#include <cerrno>
#include <cmath>
#include <thread>

#include "firmware_bridge/firmware/rotation.hpp"

namespace glint::host {

namespace {
constexpr double kTwoPi = 6.283185307179586;
std::int32_t int32_at(const std::uint16_t* r, int hi) {
    return std::int32_t((std::uint32_t(r[hi]) << 16) | r[hi + 1]);
}
}  // namespace

glm::dquat head_orientation(double azimuth_rad, double elevation_rad) {
    const firmware::Quatd yaw = firmware::Quatd::from_axis_angle({0, 1, 0}, -azimuth_rad);
    const firmware::Quatd pitch = firmware::Quatd::from_axis_angle({1, 0, 0}, elevation_rad);
    return to_glm(yaw * pitch);
}

ModbusHeadSource::ModbusHeadSource(std::string name, recording::Clock& clock, SourceOptions options,
                                   ModbusHeadOptions head)
    : OrientationSource(std::move(name), clock, options), head_(head) {
    if (!(head_.poll_hz > 0 && head_.poll_hz <= 1000)) throw SourceError(this->name() + ": poll rate must be in (0, 1000] Hz");
    if (head_.unit_id < 1 || head_.unit_id > 247) throw SourceError(this->name() + ": unit id must be 1..247");
}

std::unique_ptr<ModbusHeadSource> ModbusHeadSource::tcp(std::string name, std::string host, int port,
                                                        recording::Clock& clock, SourceOptions options,
                                                        ModbusHeadOptions head) {
    return open(true, std::move(name), std::move(host), port, clock, options, head);
}

std::unique_ptr<ModbusHeadSource> ModbusHeadSource::rtu(std::string name, std::string device, int baud,
                                                        recording::Clock& clock, SourceOptions options,
                                                        ModbusHeadOptions head) {
    return open(false, std::move(name), std::move(device), baud, clock, options, head);
}

std::unique_ptr<ModbusHeadSource> ModbusHeadSource::open(bool is_tcp, std::string name, std::string endpoint,
                                                         int port_or_baud, recording::Clock& clock,
                                                         SourceOptions options, ModbusHeadOptions head) {
    std::unique_ptr<ModbusHeadSource> s(new ModbusHeadSource(std::move(name), clock, options, head));
    s->is_tcp_ = is_tcp;
    s->endpoint_ = std::move(endpoint);
    s->port_or_baud_ = port_or_baud;
    // RTU framing is fixed at 8N1 (MODBUS.md).
    s->ctx_ = is_tcp ? modbus_new_tcp(s->endpoint_.c_str(), port_or_baud)
                     : modbus_new_rtu(s->endpoint_.c_str(), port_or_baud, 'N', 8, 1);
    if (!s->ctx_) {
        const int error = errno;  // before building the message can touch errno
        throw SourceError(s->name() + ": libmodbus refused the " + (is_tcp ? "endpoint" : "device") + ": " +
                          modbus_strerror(error));
    }
    return s;
}

ModbusHeadSource::~ModbusHeadSource() {
    stop();
    if (ctx_) modbus_free(ctx_);
}

void ModbusHeadSource::start() {
    if (thread_.joinable()) return;
    stopping_ = false;
    set_state(LinkState::Connecting);
    thread_ = std::thread([this] { run(); });
}

void ModbusHeadSource::stop() {
    stopping_ = true;
    if (thread_.joinable()) thread_.join();
    if (connected_) modbus_close(ctx_);
    connected_ = false;
    set_state(LinkState::Stopped);
}

void ModbusHeadSource::wait_interruptible(int ms) {
    const auto end = std::chrono::steady_clock::now() + std::chrono::milliseconds(ms);
    while (!stopping_ && std::chrono::steady_clock::now() < end) std::this_thread::sleep_for(std::chrono::milliseconds(5));
}

bool ModbusHeadSource::connect() {
    const std::string where =
        is_tcp_ ? endpoint_ + ":" + std::to_string(port_or_baud_) : endpoint_ + " at " + std::to_string(port_or_baud_) + " baud";
    modbus_set_slave(ctx_, head_.unit_id);
    const auto t = head_.response_timeout;
    modbus_set_response_timeout(ctx_, std::uint32_t(t.count() / 1000), std::uint32_t((t.count() % 1000) * 1000));
    if (modbus_connect(ctx_) != 0) {
        note_error(name() + ": cannot connect to " + where + ": " + modbus_strerror(errno));
        return false;
    }
    connected_ = true;
    if (ever_connected_) edit_health([](LinkHealth& h) { ++h.reconnects; });
    ever_connected_ = true;
    same_heartbeat_ = 0;
    set_state(LinkState::Connecting);
    return true;
}

void ModbusHeadSource::disconnect(const std::string& why) {
    if (connected_) modbus_close(ctx_);
    connected_ = false;
    note_error(name() + ": " + why);
    set_state(LinkState::Disconnected);
}

bool ModbusHeadSource::poll_once() {
    std::uint16_t r[modbus_map::kRegisterCount] = {};
    const std::int64_t before = now_ns();
    int rc = -1;
    for (int attempt = 0; attempt <= head_.retries && !stopping_; ++attempt) {
        rc = modbus_read_input_registers(ctx_, modbus_map::kFirstRegister, modbus_map::kRegisterCount, r);
        if (rc == modbus_map::kRegisterCount) break;
        if (rc >= 0) errno = EMBBADDATA;  // a short answer
        modbus_flush(ctx_);  // drop whatever half answer is left before asking again
    }
    const std::int64_t after = now_ns();
    if (rc != modbus_map::kRegisterCount) {
        const std::string why = modbus_strerror(errno);
        edit_health([](LinkHealth& h) { ++h.timeouts; });
        note_error(name() + ": no answer to the register read (" + why + ")");
        return false;
    }
    const auto reject = [&](const std::string& why) {
        edit_health([](LinkHealth& h) { ++h.frame_errors; });
        note_error(name() + ": " + why + "; not used");
        return true;  // the link works; the data is unusable
    };
    const std::uint16_t status = r[modbus_map::kStatus];
    if (status & modbus_map::kStatusFault) return reject("the head reports a fault (status bit 2)");
    if (status & modbus_map::kStatusEncoderError) return reject("the head reports an encoder error (status bit 3)");
    if (r[modbus_map::kHeartbeat] == last_heartbeat_) {
        if (++same_heartbeat_ >= head_.heartbeat_polls)
            return reject("heartbeat stuck at " + std::to_string(last_heartbeat_) + " for " +
                          std::to_string(same_heartbeat_) + " polls (controller frozen)");
    } else {
        same_heartbeat_ = 0;
        last_heartbeat_ = r[modbus_map::kHeartbeat];
    }
    const std::uint32_t cpr = std::uint32_t(int32_at(r, modbus_map::kCountsPerRevHi));
    const std::int32_t az = int32_at(r, modbus_map::kAzimuthHi);
    const std::int32_t el = int32_at(r, modbus_map::kElevationHi);
    if (cpr == 0 || cpr > (1u << 24)) return reject("counts per revolution " + std::to_string(cpr) + " is implausible");
    if (std::int64_t(std::abs(std::int64_t(az))) >= std::int64_t(cpr))
        return reject("azimuth " + std::to_string(az) + " counts is beyond one revolution (" + std::to_string(cpr) + ")");
    if (std::int64_t(std::abs(std::int64_t(el))) * 4 > std::int64_t(cpr))
        return reject("elevation " + std::to_string(el) + " counts is beyond +-90 degrees");
    OrientationSample s;
    s.t_ns = before + (after - before) / 2;  // the registers were read somewhere in the request
    s.world_from_sensor = head_orientation(kTwoPi * az / double(cpr), kTwoPi * el / double(cpr));
    publish(s);
    return true;
}

void ModbusHeadSource::run() {
    int backoff = head_.backoff_min_ms;
    int failures = 0;
    const auto period = std::chrono::duration<double>(1.0 / head_.poll_hz);
    auto next = std::chrono::steady_clock::now();
    while (!stopping_) {
        if (!connected_) {
            if (!connect()) {
                set_state(LinkState::Disconnected);
                wait_interruptible(backoff);
                backoff = std::min(head_.backoff_max_ms, backoff * 2);
                continue;
            }
            backoff = head_.backoff_min_ms;
            failures = 0;
        }
        if (poll_once()) {
            failures = 0;
        } else if (++failures >= head_.reconnect_after) {
            disconnect("no answer to " + std::to_string(failures) + " polls in a row; reconnecting");
            continue;
        }
        check_stall();
        next += std::chrono::duration_cast<std::chrono::steady_clock::duration>(period);
        const auto now = std::chrono::steady_clock::now();
        if (next < now) next = now;
        while (!stopping_ && std::chrono::steady_clock::now() < next)
            std::this_thread::sleep_for(std::min<std::chrono::steady_clock::duration>(next - std::chrono::steady_clock::now(),
                                                                                      std::chrono::milliseconds(5)));
    }
}

}  // namespace glint::host
