// A simulated Modbus pan/tilt head (the fake beside ModbusHeadSource's real libmodbus client):
// a libmodbus server with the register map of MODBUS.md, over TCP on 127.0.0.1 or RTU on a
// pseudo-terminal, whose angles, status bits and heartbeat the test (or a tool) sets, and which
// can stop answering. Used by the tests; runs its server loop on its own thread.
#pragma once

#include <atomic>
#include <cstdint>
#include <memory>
#include <mutex>
#include <string>
#include <thread>

typedef struct _modbus modbus_t;
typedef struct _modbus_mapping_t modbus_mapping_t;

namespace glint::host {

class ModbusHeadSimulator {
public:
    // TCP on 127.0.0.1; port 0 lets the kernel choose (see port()). Throws std::runtime_error.
    static std::unique_ptr<ModbusHeadSimulator> tcp(int port = 0, int unit_id = 1);
    // RTU on a new pseudo-terminal; clients open device(). Throws std::runtime_error.
    static std::unique_ptr<ModbusHeadSimulator> rtu(int unit_id = 1);
    ~ModbusHeadSimulator();

    int port() const { return port_; }
    const std::string& device() const { return device_; }

    void set_angles(double azimuth_deg, double elevation_deg);
    void set_counts_per_revolution(std::uint32_t counts);
    void set_status(std::uint16_t status);
    void set_raw_register(int index, std::uint16_t value);  // anything, for garbage tests
    void set_answering(bool answering);  // false: requests are received and dropped
    void freeze_heartbeat(bool frozen);  // true: the heartbeat stops moving
    std::uint64_t requests() const { return requests_; }

private:
    ModbusHeadSimulator() = default;
    void start_thread();
    void serve_tcp();
    void serve_rtu();
    bool serve_one(std::uint8_t* query);  // false: the connection ended

    modbus_t* ctx_ = nullptr;
    modbus_mapping_t* map_ = nullptr;
    int listen_fd_ = -1;
    int pty_master_ = -1, pty_slave_ = -1;
    int port_ = 0;
    std::string device_;
    bool tcp_ = true;
    std::uint32_t counts_per_rev_ = 36000;
    std::mutex mutex_;
    std::thread thread_;
    std::atomic<bool> stopping_{false}, answering_{true}, frozen_{false};
    std::atomic<std::uint64_t> requests_{0};
};

}  // namespace glint::host
