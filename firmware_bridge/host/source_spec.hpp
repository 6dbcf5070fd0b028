// Orientation sources named on the command line and in the appliance's config (`glint sensors --source`; README.md):
//   serial:PATH[:BAUD]            a sensor board on a serial port (default 115200)
//   i2c:/dev/i2c-N[:ADDR]         a BNO055 read directly (ADDR 0x28 or 0x29; default 0x28)
//   modbus-tcp:HOST:PORT          a Modbus pan/tilt head over TCP
//   modbus-rtu:PATH[:BAUD]        a Modbus pan/tilt head over a serial line (default 19200)
//   replay:FILE                   a recorded sensor file (firmware_bridge/recording)
// A trailing ":digits" is the baud rate (serial paths such as /dev/serial/by-path/...:1.0 keep
// their own colons: only an all-digit last field counts).
#pragma once

#include <cstdint>
#include <memory>
#include <string>

#include "firmware_bridge/host/orientation_source.hpp"

namespace glint::host {

enum class SourceKind { Serial, I2c, ModbusTcp, ModbusRtu, Replay };
const char* source_kind_name(SourceKind kind);

struct SourceSpec {
    SourceKind kind = SourceKind::Serial;
    std::string text;    // as given
    std::string path;    // device, file or host
    int baud = 0;        // serial kinds
    int port = 0;        // modbus-tcp
    std::uint8_t i2c_address = 0x28;
};

// Throws SourceError naming the spec and the field at fault.
SourceSpec parse_source_spec(const std::string& text);

// Builds the source (not started). `clock` is the appliance clock for live sources; replays
// run on their own clock (replay_source.hpp). Throws SourceError for a kind this build cannot
// make, naming it.
std::unique_ptr<OrientationSource> make_source(const SourceSpec& spec, recording::Clock& clock,
                                               SourceOptions options = {}, bool replay_realtime = false);

}  // namespace glint::host
