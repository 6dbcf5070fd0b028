#include "firmware_bridge/host/source_spec.hpp"

#include <cctype>
#include <cerrno>
#include <cstdlib>

#include "firmware_bridge/host/i2c_bno055_source.hpp"
#include "firmware_bridge/host/modbus_head_source.hpp"
#include "firmware_bridge/host/replay_source.hpp"
#include "firmware_bridge/host/serial_source.hpp"

namespace glint::host {

namespace {

bool all_digits(const std::string& s) {
    if (s.empty()) return false;
    for (char c : s)
        if (!std::isdigit(static_cast<unsigned char>(c))) return false;
    return true;
}

// Splits off a trailing ":digits" field.
std::string take_number_suffix(const std::string& rest, std::string& number) {
    const std::size_t colon = rest.rfind(':');
    if (colon != std::string::npos && all_digits(rest.substr(colon + 1))) {
        number = rest.substr(colon + 1);
        return rest.substr(0, colon);
    }
    number.clear();
    return rest;
}

int to_int(const std::string& digits, const std::string& spec, const char* what, long lo, long hi) {
    errno = 0;
    const long v = std::strtol(digits.c_str(), nullptr, 10);
    if (errno != 0 || v < lo || v > hi)
        throw SourceError("source '" + spec + "': " + what + " " + digits + " is out of range (" + std::to_string(lo) +
                          ".." + std::to_string(hi) + ")");
    return int(v);
}

}  // namespace

const char* source_kind_name(SourceKind kind) {
    switch (kind) {
        case SourceKind::Serial: return "serial";
        case SourceKind::I2c: return "i2c";
        case SourceKind::ModbusTcp: return "modbus-tcp";
        case SourceKind::ModbusRtu: return "modbus-rtu";
        case SourceKind::Replay: return "replay";
    }
    return "unknown";
}

SourceSpec parse_source_spec(const std::string& text) {
    SourceSpec s;
    s.text = text;
    const std::size_t colon = text.find(':');
    if (colon == std::string::npos)
        throw SourceError("source '" + text +
                          "': expected KIND:..., one of serial:PATH[:BAUD], i2c:/dev/i2c-N[:ADDR], "
                          "modbus-tcp:HOST:PORT, modbus-rtu:PATH[:BAUD], replay:FILE");
    const std::string kind = text.substr(0, colon);
    const std::string rest = text.substr(colon + 1);
    if (rest.empty()) throw SourceError("source '" + text + "': nothing after '" + kind + ":'");
    std::string number;
    if (kind == "serial" || kind == "modbus-rtu") {
        s.kind = kind == "serial" ? SourceKind::Serial : SourceKind::ModbusRtu;
        s.path = take_number_suffix(rest, number);
        s.baud = number.empty() ? (s.kind == SourceKind::Serial ? 115200 : 19200)
                                : to_int(number, text, "baud rate", 1200, 4'000'000);
        if (!serial_baud_supported(s.baud))
            throw SourceError("source '" + text + "': baud rate " + std::to_string(s.baud) + " is not a standard rate");
        if (s.path.empty()) throw SourceError("source '" + text + "': no device path");
    } else if (kind == "i2c") {
        s.kind = SourceKind::I2c;
        const std::size_t c = rest.rfind(':');
        std::string addr;
        s.path = rest;
        if (c != std::string::npos && rest.substr(c + 1).rfind("0x", 0) == 0) {
            addr = rest.substr(c + 1);
            s.path = rest.substr(0, c);
        } else if (c != std::string::npos && all_digits(rest.substr(c + 1))) {
            addr = rest.substr(c + 1);
            s.path = rest.substr(0, c);
        }
        if (!addr.empty()) {
            char* end = nullptr;
            const long a = std::strtol(addr.c_str(), &end, 0);
            if (*end != '\0' || (a != 0x28 && a != 0x29))
                throw SourceError("source '" + text + "': I2C address " + addr + " is not a BNO055's (0x28 or 0x29)");
            s.i2c_address = std::uint8_t(a);
        }
        if (s.path.rfind("/dev/i2c-", 0) != 0 || !all_digits(s.path.substr(9)))
            throw SourceError("source '" + text + "': expected an i2c-dev device /dev/i2c-N, got '" + s.path + "'");
    } else if (kind == "modbus-tcp") {
        s.kind = SourceKind::ModbusTcp;
        s.path = take_number_suffix(rest, number);
        if (number.empty()) throw SourceError("source '" + text + "': expected modbus-tcp:HOST:PORT");
        s.port = to_int(number, text, "TCP port", 1, 65535);
        if (s.path.empty()) throw SourceError("source '" + text + "': no host");
    } else if (kind == "replay") {
        s.kind = SourceKind::Replay;
        s.path = rest;
    } else {
        throw SourceError("source '" + text + "': unknown kind '" + kind +
                          "' (serial, i2c, modbus-tcp, modbus-rtu or replay)");
    }
    return s;
}

std::unique_ptr<OrientationSource> make_source(const SourceSpec& spec, recording::Clock& clock,
                                               SourceOptions options, bool replay_realtime) {
    switch (spec.kind) {
        case SourceKind::Serial: {
            SerialOptions o;
            o.path = spec.path;
            o.baud = spec.baud;
            return std::make_unique<SerialSource>(spec.text, o, clock, options);
        }
        case SourceKind::Replay:
            return std::make_unique<ReplaySource>(
                spec.text, spec.path, replay_realtime ? ReplayPacing::Realtime : ReplayPacing::Fast, options);
        case SourceKind::I2c:
            return std::make_unique<LinuxBno055Source>(spec.text, spec.path, spec.i2c_address, clock, options);
        case SourceKind::ModbusTcp:
            return ModbusHeadSource::tcp(spec.text, spec.path, spec.port, clock, options);
        case SourceKind::ModbusRtu:
            return ModbusHeadSource::rtu(spec.text, spec.path, spec.baud, clock, options);
    }
    throw SourceError("source '" + spec.text + "': unknown kind");
}

}  // namespace glint::host
