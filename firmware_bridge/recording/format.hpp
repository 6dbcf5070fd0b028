// The recorded-sensor file format (FORMAT.md is the byte-by-byte specification; this header is
// its code side): constants, the file header, the five record kinds, and their encoding to and
// parsing from bytes. No file I/O here: recorder.hpp writes files, reader.hpp reads them.
//
// All times in records are microseconds of the appliance's CLOCK_MONOTONIC (the clock the host
// driver stamps received chunks with), never the sensor board's clock; board timestamps live
// only inside decoded protocol messages.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <span>
#include <stdexcept>
#include <string>
#include <utility>
#include <variant>
#include <vector>

#include "firmware_bridge/protocol/messages.hpp"

namespace glint::recording {

using Bytes = std::vector<std::uint8_t>;

// Format version of files this code writes. A reader accepts every minor version of its major
// version (newer minors only append header fields and add record types, which it skips) and
// refuses a newer major version.
inline constexpr std::uint16_t kFormatMajor = 1;
inline constexpr std::uint16_t kFormatMinor = 0;

// "GLINTREC": the first 8 bytes of every recording.
inline constexpr std::array<std::uint8_t, 8> kMagic{'G', 'L', 'I', 'N', 'T', 'R', 'E', 'C'};
// magic | format_major | format_minor | header_size: enough to identify a file and its version.
inline constexpr std::size_t kPreambleSize = 16;
// Smallest header of version 1.0: the fixed fields, empty strings, no notes, the CRC.
inline constexpr std::size_t kMinHeaderSize = 48;
// A header larger than this is taken as corrupt rather than read (notes are short key=value text).
inline constexpr std::size_t kMaxHeaderSize = 1u << 20;

// Every record starts with these 4 bytes, so a reader can find the next record after a damaged
// one (FORMAT.md "Resynchronisation").
inline constexpr std::array<std::uint8_t, 4> kRecordSync{0xAB, 'R', 'E', 'C'};
// sync | payload_size u32 | type u16 | flags u16 | CRC-32C u32
inline constexpr std::size_t kRecordHeaderSize = 16;
// Largest payload a reader accepts; a bigger size field is corruption. The recorder splits raw
// chunks so that its records stay far below this.
inline constexpr std::size_t kMaxRecordPayload = 1u << 20;
// Raw chunks longer than this are written as several records (keeps records small so a torn
// write loses little).
inline constexpr std::size_t kMaxRawChunk = 64u * 1024u;

// How the appliance talks to the sensor (header field `transport`).
enum class Transport : std::uint8_t {
    Unknown = 0,
    Serial = 1,     // UART / USB CDC byte stream carrying protocol frames
    I2c = 2,        // i2c-dev register reads
    Modbus = 3,     // Modbus RTU/TCP (libmodbus)
    Gpio = 4,       // GPIO lines only (buttons, lamps)
    Simulator = 5,  // a simulated board (e.g. the firmware's host build on a pseudo-terminal)
};
const char* transport_name(Transport transport);
// Whether a recording of this transport carries the sensor's byte stream (raw-bytes records a
// replay decodes again): serial and simulated boards, and files that do not say. An I2C BNO055
// or a Modbus head has registers, not frames: its recordings hold each published sample as a
// decoded Orientation message alone (FORMAT.md 3.2, "Sources without a byte stream"). GPIO
// recordings have no byte stream either.
bool transport_has_byte_stream(Transport transport);
// Inverse of transport_name; nullopt for an unknown name.
std::optional<Transport> transport_from_name(const std::string& name);

struct Note {
    std::string key;    // non-empty, no '=' and no control characters
    std::string value;  // free text, no control characters
    friend bool operator==(const Note&, const Note&) = default;
};

// Everything the header says about the recording (FORMAT.md section 2).
struct FileHeader {
    std::uint16_t format_major = kFormatMajor;
    std::uint16_t format_minor = kFormatMinor;
    std::uint32_t header_size = 0;              // bytes; records start at this file offset
    std::int64_t created_unix_us = 0;           // wall clock (CLOCK_REALTIME), µs since 1970 UTC
    std::uint64_t created_monotonic_us = 0;     // appliance CLOCK_MONOTONIC at creation, µs
    Transport transport = Transport::Unknown;
    std::uint8_t protocol_major = protocol::kVersionMajor;  // protocol of the decoded records
    std::uint8_t protocol_minor = protocol::kVersionMinor;
    std::uint32_t baud = 0;                     // serial line rate in bit/s, 0 when not serial
    std::vector<std::uint8_t> decoded_types;    // message types recorded as DecodedMessage records
    std::string device;                         // e.g. "/dev/ttyACM0", "/dev/i2c-1:0x28"
    std::vector<Note> notes;
    friend bool operator==(const FileHeader&, const FileHeader&) = default;
};

enum class RecordType : std::uint16_t {
    RawBytes = 1,
    DecodedMessage = 2,
    GpioEvent = 3,
    Marker = 4,
    StreamRestart = 5,
};
const char* record_type_name(std::uint16_t type);

enum class Direction : std::uint8_t {
    Received = 0,  // device -> appliance (what the decoder is fed)
    Sent = 1,      // appliance -> device
};

// (a) Transport bytes exactly as one read() returned them.
struct RawBytesRecord {
    std::uint64_t time_us = 0;        // appliance monotonic time when the chunk was read
    std::uint64_t stream_offset = 0;  // bytes of this direction before the chunk, since the
                                      // file start or the last StreamRestart
    Direction direction = Direction::Received;
    Bytes bytes;
    friend bool operator==(const RawBytesRecord&, const RawBytesRecord&) = default;
};

// (b) A message the live decoder accepted (FrameStatus::Ok).
struct DecodedMessageRecord {
    std::uint64_t host_time_us = 0;   // time_us of the raw chunk in which the frame ended
    std::uint64_t stream_offset = 0;  // FrameEvent::offset: received-stream offset of the frame
    std::uint16_t seq = 0;            // the frame's sequence number
    protocol::Message message;        // board timestamps are inside (board clock, µs)
    friend bool operator==(const DecodedMessageRecord&, const DecodedMessageRecord&) = default;
};

enum class Edge : std::uint8_t { Falling = 0, Rising = 1 };

// (c) An edge on a GPIO line.
struct GpioEventRecord {
    std::uint64_t time_us = 0;  // appliance monotonic time of the edge (libgpiod's event time)
    std::uint32_t line = 0;     // line offset on its chip
    Edge edge = Edge::Rising;
    std::string chip;           // e.g. "gpiochip0"; may be empty
    friend bool operator==(const GpioEventRecord&, const GpioEventRecord&) = default;
};

// (d) A free-text annotation ("capture started").
struct MarkerRecord {
    std::uint64_t time_us = 0;
    std::string text;
    friend bool operator==(const MarkerRecord&, const MarkerRecord&) = default;
};

// The transport was reopened: stream offsets restart at 0 and a replay resets its decoder.
struct StreamRestartRecord {
    std::uint64_t time_us = 0;
    std::string reason;
    friend bool operator==(const StreamRestartRecord&, const StreamRestartRecord&) = default;
};

// A record of a type this version does not know (written by a newer minor version).
struct UnknownRecord {
    std::uint16_t type = 0;
    std::uint16_t flags = 0;
    Bytes payload;
    friend bool operator==(const UnknownRecord&, const UnknownRecord&) = default;
};

using RecordBody = std::variant<RawBytesRecord, DecodedMessageRecord, GpioEventRecord, MarkerRecord,
                                StreamRestartRecord, UnknownRecord>;

// Time of a record in appliance monotonic µs (nullopt for unknown records).
std::optional<std::uint64_t> record_time_us(const RecordBody& body);
std::uint16_t record_type_of(const RecordBody& body);

// A record as read from a file: its body and where it starts.
struct Record {
    std::uint64_t offset = 0;  // file offset of the record's sync bytes
    std::uint32_t size = 0;    // record bytes, header included
    RecordBody body;
};

// Thrown when a header or a record cannot be built or parsed; the message names the byte offset.
class FormatError : public std::runtime_error {
public:
    using std::runtime_error::runtime_error;
};

// Thrown when a recording cannot be created or opened; the message names the file.
class RecordingError : public std::runtime_error {
public:
    using std::runtime_error::runtime_error;
};

// The message types a board sends (Hello .. ConfigAck): what a recorder keeps as decoded
// messages unless told otherwise.
std::vector<std::uint8_t> board_message_types();

// Throws FormatError for headers that cannot be written (strings too long, bad note keys, more
// than 255 decoded types).
Bytes encode_header(const FileHeader& header);

// Whole record: header, CRC and payload. Throws FormatError when the payload would exceed
// kMaxRecordPayload or a Message cannot be encoded.
Bytes encode_record(const RecordBody& body);

// Parses and validates a complete header. `bytes` holds the file's first bytes (all of them when
// the file is shorter than the header). Throws FormatError naming the byte offset.
FileHeader parse_header(std::span<const std::uint8_t> bytes);

// Outcome of parsing the record that starts at bytes[0].
enum class RecordCheck : std::uint8_t {
    Ok,
    NeedMore,      // the record (or its header) continues past the end of `bytes`
    BadSync,       // no sync marker here
    BadSize,       // payload_size above kMaxRecordPayload
    BadCrc,        // CRC mismatch
    Malformed,     // CRC correct but the payload does not fit its type's layout
};
const char* check_name(RecordCheck check);

struct RecordParse {
    RecordCheck check = RecordCheck::NeedMore;
    std::size_t size = 0;          // record bytes (header + payload) when known
    std::optional<RecordBody> body;  // when Ok
    std::string detail;            // why, for Malformed
};

// Checks the record starting at bytes[0] (sync, size, CRC, payload layout).
RecordParse parse_record(std::span<const std::uint8_t> bytes);

}  // namespace glint::recording
