// A motorised pan/tilt head that reports its encoder angles over Modbus (libmodbus: TCP, or RTU
// on a serial line), as an orientation source. The register map is MODBUS.md: status, heartbeat,
// azimuth and elevation encoder counts (32-bit, high word first) and counts per revolution, all
// input registers (function 0x04) from address 0.
//
// Frame: azimuth turns about world +Y, 0 = looking along -Z (north), positive clockwise seen from
// above (towards +X, east); elevation turns about the camera's +X after that, positive up. So
// world_from_camera = Ry(-azimuth) * Rx(elevation); the head has no roll.
//
// Faults: a request without an answer within `response_timeout` is retried `retries` times; a poll
// that still fails counts one timeout; `reconnect_after` failed polls in a row close the
// connection (Disconnected) and reopen it with back-off, a success counting one reconnect.
// Register values that cannot be an orientation (counts beyond a revolution, elevation beyond
// +-90 degrees, zero counts per revolution, the fault or encoder-error bits, a heartbeat that has
// not moved for `heartbeat_polls`) are counted as frame errors, named in last_error and never
// published.
#pragma once

#include <atomic>
#include <chrono>
#include <string>
#include <thread>

#include "firmware_bridge/host/orientation_source.hpp"

typedef struct _modbus modbus_t;

namespace glint::host {

namespace modbus_map {
inline constexpr int kFirstRegister = 0;
inline constexpr int kRegisterCount = 8;
inline constexpr int kStatus = 0;       // bits below
inline constexpr int kHeartbeat = 1;    // increments with every encoder update (wraps at 65536)
inline constexpr int kAzimuthHi = 2;    // int32 counts, high word first
inline constexpr int kElevationHi = 4;  // int32 counts, high word first
inline constexpr int kCountsPerRevHi = 6;  // uint32, high word first
inline constexpr std::uint16_t kStatusReady = 1u << 0;
inline constexpr std::uint16_t kStatusMoving = 1u << 1;
inline constexpr std::uint16_t kStatusFault = 1u << 2;
inline constexpr std::uint16_t kStatusEncoderError = 1u << 3;
}  // namespace modbus_map

struct ModbusHeadOptions {
    int unit_id = 1;
    double poll_hz = 50;
    std::chrono::milliseconds response_timeout{100};
    int retries = 2;            // extra attempts per poll
    int reconnect_after = 3;    // failed polls in a row before the connection is reopened
    int heartbeat_polls = 25;   // polls with the same heartbeat before the head counts as frozen
    int backoff_min_ms = 50;
    int backoff_max_ms = 1000;
};

// Orientation of a head at (azimuth, elevation) in radians, as documented above.
glm::dquat head_orientation(double azimuth_rad, double elevation_rad);

class ModbusHeadSource final : public OrientationSource {
public:
    static std::unique_ptr<ModbusHeadSource> tcp(std::string name, std::string host, int port, recording::Clock& clock,
                                                 SourceOptions options = {}, ModbusHeadOptions head = {});
    static std::unique_ptr<ModbusHeadSource> rtu(std::string name, std::string device, int baud,
                                                 recording::Clock& clock, SourceOptions options = {},
                                                 ModbusHeadOptions head = {});
    ~ModbusHeadSource() override;

    void start() override;
    void stop() override;

private:
    ModbusHeadSource(std::string name, recording::Clock& clock, SourceOptions options, ModbusHeadOptions head);
    // What tcp() and rtu() share: the source, its libmodbus context (TCP when is_tcp, else RTU on a
    // serial device) and the error when libmodbus refuses the endpoint.
    static std::unique_ptr<ModbusHeadSource> open(bool is_tcp, std::string name, std::string endpoint,
                                                  int port_or_baud, recording::Clock& clock,
                                                  SourceOptions options, ModbusHeadOptions head);
    void run();
    bool connect();
    void disconnect(const std::string& why);
    bool poll_once();  // false: the request failed
    void wait_interruptible(int ms);

    ModbusHeadOptions head_;
    bool is_tcp_ = true;
    std::string endpoint_;  // host or device
    int port_or_baud_ = 0;
    modbus_t* ctx_ = nullptr;
    bool connected_ = false;
    bool ever_connected_ = false;
    std::thread thread_;
    std::atomic<bool> stopping_{false};
    std::uint16_t last_heartbeat_ = 0;
    int same_heartbeat_ = 0;
};

}  // namespace glint::host
