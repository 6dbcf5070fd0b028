// parse_source_spec (firmware_bridge/host/source_spec.cpp): every spec form, the defaults, the
// rule that only an all-digit last field is a baud rate, and the rejections. Every rejection must
// name the spec as given, since the user typed it on a command line or in a config file.
#include <gtest/gtest.h>

#include <string>

#include "firmware_bridge/host/source_spec.hpp"

namespace glint::host {
namespace {

// The message of the SourceError parse_source_spec throws, or a failure if it accepts the text.
std::string rejection(const std::string& text) {
    try {
        const SourceSpec s = parse_source_spec(text);
        ADD_FAILURE() << "'" << text << "' was accepted (path '" << s.path << "', baud " << s.baud << ")";
        return {};
    } catch (const SourceError& e) {
        return e.what();
    }
}

// The rejection names the spec as given (quoted) and says what is wrong.
void expect_rejected(const std::string& text, const std::string& reason) {
    SCOPED_TRACE(text);
    const std::string message = rejection(text);
    EXPECT_NE(message.find("source '" + text + "'"), std::string::npos) << message;
    EXPECT_NE(message.find(reason), std::string::npos) << message;
}

TEST(SourceSpec, SerialDefaultsTo115200) {
    const SourceSpec s = parse_source_spec("serial:/dev/ttyACM0");
    EXPECT_EQ(s.kind, SourceKind::Serial);
    EXPECT_EQ(s.text, "serial:/dev/ttyACM0");
    EXPECT_EQ(s.path, "/dev/ttyACM0");
    EXPECT_EQ(s.baud, 115200);
}

TEST(SourceSpec, SerialTakesAStandardBaudRate) {
    const SourceSpec s = parse_source_spec("serial:/dev/ttyUSB1:921600");
    EXPECT_EQ(s.kind, SourceKind::Serial);
    EXPECT_EQ(s.path, "/dev/ttyUSB1");
    EXPECT_EQ(s.baud, 921600);
    // The table's ends, so an off-by-one in either direction of the table shows.
    EXPECT_EQ(parse_source_spec("serial:/dev/ttyS0:9600").baud, 9600);
    EXPECT_EQ(parse_source_spec("serial:/dev/ttyS0:4000000").baud, 4000000);
}

TEST(SourceSpec, ModbusRtuDefaultsTo19200) {
    const SourceSpec s = parse_source_spec("modbus-rtu:/dev/ttyS1");
    EXPECT_EQ(s.kind, SourceKind::ModbusRtu);
    EXPECT_EQ(s.path, "/dev/ttyS1");
    EXPECT_EQ(s.baud, 19200);
    const SourceSpec fast = parse_source_spec("modbus-rtu:/dev/ttyS1:38400");
    EXPECT_EQ(fast.path, "/dev/ttyS1");
    EXPECT_EQ(fast.baud, 38400);
}

// /dev/serial/by-path names carry colons of their own; only an all-digit last field is a baud.
TEST(SourceSpec, ColonsInsideASerialPathStayInThePath) {
    const std::string by_path = "/dev/serial/by-path/pci-0000:00:14.0-usb-0:1.2:1.0";
    const SourceSpec plain = parse_source_spec("serial:" + by_path);
    EXPECT_EQ(plain.path, by_path);
    EXPECT_EQ(plain.baud, 115200);
    const SourceSpec with_baud = parse_source_spec("serial:" + by_path + ":57600");
    EXPECT_EQ(with_baud.path, by_path);
    EXPECT_EQ(with_baud.baud, 57600);
    const SourceSpec rtu = parse_source_spec("modbus-rtu:" + by_path + ":9600");
    EXPECT_EQ(rtu.path, by_path);
    EXPECT_EQ(rtu.baud, 9600);
    // A last field with a letter in it is part of the path, not a (bad) baud rate.
    EXPECT_EQ(parse_source_spec("serial:/dev/tty:9600x").path, "/dev/tty:9600x");
}

TEST(SourceSpec, I2cDefaultsToAddress0x28) {
    const SourceSpec s = parse_source_spec("i2c:/dev/i2c-1");
    EXPECT_EQ(s.kind, SourceKind::I2c);
    EXPECT_EQ(s.path, "/dev/i2c-1");
    EXPECT_EQ(s.i2c_address, 0x28);
}

TEST(SourceSpec, I2cTakesEitherBno055AddressInHexOrDecimal) {
    const SourceSpec hex = parse_source_spec("i2c:/dev/i2c-12:0x29");
    EXPECT_EQ(hex.path, "/dev/i2c-12");
    EXPECT_EQ(hex.i2c_address, 0x29);
    EXPECT_EQ(parse_source_spec("i2c:/dev/i2c-0:0x28").i2c_address, 0x28);
    const SourceSpec dec = parse_source_spec("i2c:/dev/i2c-3:41");
    EXPECT_EQ(dec.path, "/dev/i2c-3");
    EXPECT_EQ(dec.i2c_address, 0x29);
    EXPECT_EQ(parse_source_spec("i2c:/dev/i2c-3:40").i2c_address, 0x28);
}

TEST(SourceSpec, ModbusTcpTakesHostAndPort) {
    const SourceSpec s = parse_source_spec("modbus-tcp:head.local:502");
    EXPECT_EQ(s.kind, SourceKind::ModbusTcp);
    EXPECT_EQ(s.path, "head.local");
    EXPECT_EQ(s.port, 502);
    EXPECT_EQ(parse_source_spec("modbus-tcp:10.0.0.7:1").port, 1);
    EXPECT_EQ(parse_source_spec("modbus-tcp:10.0.0.7:65535").port, 65535);
    // The host is everything before the last colon (an IPv6 literal keeps its colons).
    const SourceSpec v6 = parse_source_spec("modbus-tcp:::1:1502");
    EXPECT_EQ(v6.path, "::1");
    EXPECT_EQ(v6.port, 1502);
}

TEST(SourceSpec, ReplayTakesTheRestVerbatim) {
    const SourceSpec s = parse_source_spec("replay:data/sessions/a:b:1200.glrec");
    EXPECT_EQ(s.kind, SourceKind::Replay);
    EXPECT_EQ(s.path, "data/sessions/a:b:1200.glrec");
    // A file name ending in ":digits" is still a file name: replays have no baud rate.
    const SourceSpec digits = parse_source_spec("replay:take:7");
    EXPECT_EQ(digits.path, "take:7");
    EXPECT_EQ(digits.baud, 0);
}

TEST(SourceSpec, KindNames) {
    EXPECT_STREQ(source_kind_name(SourceKind::Serial), "serial");
    EXPECT_STREQ(source_kind_name(SourceKind::I2c), "i2c");
    EXPECT_STREQ(source_kind_name(SourceKind::ModbusTcp), "modbus-tcp");
    EXPECT_STREQ(source_kind_name(SourceKind::ModbusRtu), "modbus-rtu");
    EXPECT_STREQ(source_kind_name(SourceKind::Replay), "replay");
}

TEST(SourceSpec, RejectsTextWithoutAKind) {
    expect_rejected("/dev/ttyACM0", "expected KIND:");
    expect_rejected("", "expected KIND:");
}

TEST(SourceSpec, RejectsAnUnknownKind) { expect_rejected("usb:/dev/ttyACM0", "unknown kind 'usb'"); }

TEST(SourceSpec, RejectsAnEmptyRest) {
    expect_rejected("serial:", "nothing after 'serial:'");
    expect_rejected("replay:", "nothing after 'replay:'");
}

TEST(SourceSpec, RejectsABaudRateNotInTheTable) {
    // In the numeric range but no termios constant: the driver could not set it.
    expect_rejected("serial:/dev/ttyUSB0:1200", "baud rate 1200 is not a standard rate");
    expect_rejected("serial:/dev/ttyUSB0:115201", "baud rate 115201 is not a standard rate");
    expect_rejected("modbus-rtu:/dev/ttyS1:14400", "baud rate 14400 is not a standard rate");
}

TEST(SourceSpec, RejectsABaudRateOutOfRange) {
    expect_rejected("serial:/dev/ttyUSB0:0", "baud rate 0 is out of range");
    expect_rejected("serial:/dev/ttyUSB0:8000000", "baud rate 8000000 is out of range");
    // Too long for a long: strtol's ERANGE must not wrap into an accepted rate.
    expect_rejected("serial:/dev/ttyUSB0:99999999999999999999999", "is out of range");
}

TEST(SourceSpec, RejectsASerialSpecWithoutAPath) {
    expect_rejected("serial::115200", "no device path");
    expect_rejected("modbus-rtu::9600", "no device path");
}

TEST(SourceSpec, RejectsAnAddressThatIsNotABno055s) {
    expect_rejected("i2c:/dev/i2c-1:0x30", "I2C address 0x30 is not a BNO055's");
    expect_rejected("i2c:/dev/i2c-1:39", "I2C address 39 is not a BNO055's");
    expect_rejected("i2c:/dev/i2c-1:0x2g", "I2C address 0x2g");
}

TEST(SourceSpec, RejectsAnI2cPathThatIsNotAnI2cDevDevice) {
    expect_rejected("i2c:/dev/spidev0.0", "expected an i2c-dev device /dev/i2c-N, got '/dev/spidev0.0'");
    expect_rejected("i2c:/dev/i2c-", "got '/dev/i2c-'");
    expect_rejected("i2c:/dev/i2c-1a:0x28", "got '/dev/i2c-1a'");
}

TEST(SourceSpec, RejectsModbusTcpWithoutAValidPort) {
    expect_rejected("modbus-tcp:head.local", "expected modbus-tcp:HOST:PORT");
    expect_rejected("modbus-tcp:head.local:http", "expected modbus-tcp:HOST:PORT");
    expect_rejected("modbus-tcp:head.local:0", "TCP port 0 is out of range (1..65535)");
    expect_rejected("modbus-tcp:head.local:65536", "TCP port 65536 is out of range");
    expect_rejected("modbus-tcp::502", "no host");
}

}  // namespace
}  // namespace glint::host
