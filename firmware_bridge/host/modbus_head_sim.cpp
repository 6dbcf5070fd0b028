#include "firmware_bridge/host/modbus_head_sim.hpp"

#include <arpa/inet.h>
#include <modbus/modbus.h>
#include <netinet/in.h>
#include <pty.h>
#include <sys/select.h>
#include <sys/socket.h>
#include <termios.h>
#include <unistd.h>

#include <cerrno>
#include <cmath>
#include <stdexcept>

#include "firmware_bridge/host/modbus_head_source.hpp"

namespace glint::host {

namespace {
void put_int32(std::uint16_t* regs, int hi, std::int32_t v) {
    const std::uint32_t u = std::uint32_t(v);
    regs[hi] = std::uint16_t(u >> 16);
    regs[hi + 1] = std::uint16_t(u & 0xFFFF);
}
}  // namespace

std::unique_ptr<ModbusHeadSimulator> ModbusHeadSimulator::tcp(int port, int unit_id) {
    std::unique_ptr<ModbusHeadSimulator> s(new ModbusHeadSimulator());
    s->tcp_ = true;
    s->ctx_ = modbus_new_tcp("127.0.0.1", port);
    if (!s->ctx_) throw std::runtime_error(std::string("modbus_new_tcp: ") + modbus_strerror(errno));
    modbus_set_slave(s->ctx_, unit_id);
    s->listen_fd_ = modbus_tcp_listen(s->ctx_, 1);
    if (s->listen_fd_ < 0) throw std::runtime_error(std::string("modbus_tcp_listen: ") + modbus_strerror(errno));
    sockaddr_in addr{};
    socklen_t len = sizeof addr;
    getsockname(s->listen_fd_, reinterpret_cast<sockaddr*>(&addr), &len);
    s->port_ = ntohs(addr.sin_port);
    s->start_thread();
    return s;
}

std::unique_ptr<ModbusHeadSimulator> ModbusHeadSimulator::rtu(int unit_id) {
    std::unique_ptr<ModbusHeadSimulator> s(new ModbusHeadSimulator());
    s->tcp_ = false;
    char name[256] = {};
    if (openpty(&s->pty_master_, &s->pty_slave_, name, nullptr, nullptr) != 0)
        throw std::runtime_error("openpty failed for the simulated RTU head");
    termios t{};
    tcgetattr(s->pty_slave_, &t);
    cfmakeraw(&t);
    tcsetattr(s->pty_slave_, TCSANOW, &t);
    s->device_ = name;
    // The server speaks on the master side; libmodbus only needs a descriptor to read and write.
    s->ctx_ = modbus_new_rtu(name, 19200, 'N', 8, 1);
    if (!s->ctx_) throw std::runtime_error(std::string("modbus_new_rtu: ") + modbus_strerror(errno));
    modbus_set_slave(s->ctx_, unit_id);
    modbus_set_socket(s->ctx_, s->pty_master_);
    s->start_thread();
    return s;
}

void ModbusHeadSimulator::start_thread() {
    map_ = modbus_mapping_new(0, 0, 0, modbus_map::kRegisterCount);
    if (!map_) throw std::runtime_error("modbus_mapping_new failed");
    set_counts_per_revolution(counts_per_rev_);
    set_status(modbus_map::kStatusReady);
    modbus_set_indication_timeout(ctx_, 0, 50'000);  // wake up every 50 ms to notice stop
    thread_ = std::thread([this] { tcp_ ? serve_tcp() : serve_rtu(); });
}

ModbusHeadSimulator::~ModbusHeadSimulator() {
    stopping_ = true;
    if (thread_.joinable()) thread_.join();
    if (ctx_) {
        if (tcp_) modbus_close(ctx_);
        modbus_free(ctx_);
    }
    if (listen_fd_ >= 0) ::close(listen_fd_);
    if (pty_master_ >= 0) ::close(pty_master_);
    if (pty_slave_ >= 0) ::close(pty_slave_);
    if (map_) modbus_mapping_free(map_);
}

void ModbusHeadSimulator::set_angles(double azimuth_deg, double elevation_deg) {
    const std::lock_guard lock(mutex_);
    put_int32(map_->tab_input_registers, modbus_map::kAzimuthHi,
              std::int32_t(std::llround(azimuth_deg / 360.0 * counts_per_rev_)));
    put_int32(map_->tab_input_registers, modbus_map::kElevationHi,
              std::int32_t(std::llround(elevation_deg / 360.0 * counts_per_rev_)));
}

void ModbusHeadSimulator::set_counts_per_revolution(std::uint32_t counts) {
    const std::lock_guard lock(mutex_);
    counts_per_rev_ = counts;
    put_int32(map_->tab_input_registers, modbus_map::kCountsPerRevHi, std::int32_t(counts));
}

void ModbusHeadSimulator::set_status(std::uint16_t status) {
    const std::lock_guard lock(mutex_);
    map_->tab_input_registers[modbus_map::kStatus] = status;
}

void ModbusHeadSimulator::set_raw_register(int index, std::uint16_t value) {
    const std::lock_guard lock(mutex_);
    map_->tab_input_registers[index] = value;
}

void ModbusHeadSimulator::set_answering(bool answering) { answering_ = answering; }
void ModbusHeadSimulator::freeze_heartbeat(bool frozen) { frozen_ = frozen; }

bool ModbusHeadSimulator::serve_one(std::uint8_t* query) {
    const int rc = modbus_receive(ctx_, query);
    if (rc == 0) return true;  // a request for another unit: ignored
    if (rc < 0) return errno == ETIMEDOUT;  // no request within 50 ms: keep serving
    ++requests_;
    if (!answering_) return true;
    const std::lock_guard lock(mutex_);
    if (!frozen_) ++map_->tab_input_registers[modbus_map::kHeartbeat];  // an encoder update
    modbus_reply(ctx_, query, rc, map_);
    return true;
}

void ModbusHeadSimulator::serve_tcp() {
    std::uint8_t query[MODBUS_TCP_MAX_ADU_LENGTH];
    while (!stopping_) {
        fd_set set;
        FD_ZERO(&set);
        FD_SET(listen_fd_, &set);
        timeval tv{0, 50'000};
        if (select(listen_fd_ + 1, &set, nullptr, nullptr, &tv) <= 0) continue;
        int s = listen_fd_;
        if (modbus_tcp_accept(ctx_, &s) < 0) continue;
        while (!stopping_ && serve_one(query)) {
        }
        modbus_close(ctx_);  // the client went away (or we stop): wait for the next one
    }
}

void ModbusHeadSimulator::serve_rtu() {
    std::uint8_t query[MODBUS_RTU_MAX_ADU_LENGTH];
    while (!stopping_) {
        if (!serve_one(query)) modbus_flush(ctx_);  // a broken frame: drop it and listen again
    }
}

}  // namespace glint::host
