// Encoding and parsing of the recording header and records (layouts in FORMAT.md).
#include "firmware_bridge/recording/format.hpp"

#include <algorithm>
#include <cinttypes>
#include <cstdio>
#include <cstring>

#include "firmware_bridge/protocol/byte_io.hpp"
#include "firmware_bridge/protocol/crc32c.hpp"

namespace glint::recording {
namespace {

namespace bio = protocol::byte_io;

std::string hex32(std::uint32_t v) {
    char text[16];
    std::snprintf(text, sizeof text, "0x%08" PRIX32, v);
    return text;
}

// Appends little-endian fields to a byte vector.
class Writer {
public:
    explicit Writer(Bytes& out) : out_(out) {}
    void u8(std::uint8_t v) { out_.push_back(v); }
    void u16(std::uint16_t v) { grow(2); bio::put_u16(end(2), v); }
    void u32(std::uint32_t v) { grow(4); bio::put_u32(end(4), v); }
    void u64(std::uint64_t v) { grow(8); bio::put_u64(end(8), v); }
    // resize + memcpy rather than vector::insert: GCC 12 at -O3 reports false
    // -Wstringop-overflow hits inside insert's reallocation path.
    void bytes(std::span<const std::uint8_t> b) {
        if (b.empty()) return;
        grow(b.size());
        std::memcpy(end(b.size()), b.data(), b.size());
    }
    void text(const std::string& s) {
        bytes(std::span<const std::uint8_t>(reinterpret_cast<const std::uint8_t*>(s.data()), s.size()));
    }
    // u16 length, then the bytes; throws when the string does not fit 16 bits.
    void short_text(const std::string& s, const char* what) {
        if (s.size() > 0xFFFF)
            throw FormatError(std::string(what) + " is " + std::to_string(s.size()) +
                              " bytes long, at most 65535 fit the header");
        u16(static_cast<std::uint16_t>(s.size()));
        text(s);
    }

private:
    void grow(std::size_t n) { out_.resize(out_.size() + n); }
    std::uint8_t* end(std::size_t n) { return out_.data() + out_.size() - n; }
    Bytes& out_;
};

// Reads little-endian fields from a span; every read is bounds-checked and a short read throws
// FormatError naming the file offset of the field (base + position) and what was being read.
class Reader {
public:
    // `where` names the unit ("header", "record") whose byte `base` is bytes[0].
    Reader(std::span<const std::uint8_t> bytes, std::uint64_t base, const char* where)
        : bytes_(bytes), base_(base), where_(where) {}
    std::uint8_t u8(const char* what) { return *take(1, what); }
    std::uint16_t u16(const char* what) { return bio::get_u16(take(2, what)); }
    std::uint32_t u32(const char* what) { return bio::get_u32(take(4, what)); }
    std::uint64_t u64(const char* what) { return bio::get_u64(take(8, what)); }
    std::string text(std::size_t n, const char* what) {
        const std::uint8_t* p = take(n, what);
        return std::string(reinterpret_cast<const char*>(p), n);
    }
    std::span<const std::uint8_t> rest() { return bytes_.subspan(pos_); }
    std::size_t position() const { return pos_; }

private:
    const std::uint8_t* take(std::size_t n, const char* what) {
        if (bytes_.size() - pos_ < n)
            throw FormatError(std::string(what) + " at byte " + std::to_string(base_ + pos_) + " of the " +
                              where_ + " runs past its end (" + std::to_string(n) + " bytes needed, " +
                              std::to_string(bytes_.size() - pos_) + " left)");
        const std::uint8_t* p = bytes_.data() + pos_;
        pos_ += n;
        return p;
    }
    std::span<const std::uint8_t> bytes_;
    std::uint64_t base_;
    const char* where_;
    std::size_t pos_ = 0;
};

bool has_control_character(const std::string& s) {
    return std::any_of(s.begin(), s.end(), [](char c) {
        const auto u = static_cast<unsigned char>(c);
        return u < 0x20 || u == 0x7F;
    });
}

void check_header_text(const FileHeader& header) {
    if (has_control_character(header.device))
        throw FormatError("device \"" + header.device + "\" holds a control character");
    for (const Note& note : header.notes) {
        if (note.key.empty()) throw FormatError("a note has an empty key");
        if (note.key.find('=') != std::string::npos || has_control_character(note.key))
            throw FormatError("note key \"" + note.key + "\" holds '=' or a control character");
        if (has_control_character(note.value))
            throw FormatError("note " + note.key + " has a control character in its value");
    }
}

std::uint32_t record_crc(std::span<const std::uint8_t> header, std::span<const std::uint8_t> payload) {
    // Bytes 4..11 of the record header (size, type, flags), then the payload: everything but the
    // sync marker (constant) and the CRC itself.
    std::uint32_t reg = protocol::crc32c_update(protocol::kCrc32cInit, header.subspan(4, 8));
    reg = protocol::crc32c_update(reg, payload);
    return protocol::crc32c_finish(reg);
}

template <class... Fs>
struct Overloaded : Fs... {
    using Fs::operator()...;
};
template <class... Fs>
Overloaded(Fs...) -> Overloaded<Fs...>;

void encode_payload(const RecordBody& body, Bytes& out) {
    Writer w(out);
    std::visit(Overloaded{
                   [&](const RawBytesRecord& r) {
                       w.u64(r.time_us);
                       w.u64(r.stream_offset);
                       w.u8(static_cast<std::uint8_t>(r.direction));
                       w.bytes(r.bytes);
                   },
                   [&](const DecodedMessageRecord& r) {
                       w.u64(r.host_time_us);
                       w.u64(r.stream_offset);
                       w.u16(r.seq);
                       w.u8(static_cast<std::uint8_t>(r.message.type));
                       std::array<std::uint8_t, protocol::kMaxPayloadSize> payload{};
                       const protocol::PayloadResult p = protocol::encode_payload(r.message, payload);
                       if (p.status != protocol::PayloadStatus::Ok)
                           throw FormatError(std::string("cannot record a ") +
                                             protocol::type_name(static_cast<std::uint8_t>(r.message.type)) +
                                             " message: " + protocol::status_name(p.status));
                       w.bytes(std::span<const std::uint8_t>(payload.data(), p.size));
                   },
                   [&](const GpioEventRecord& r) {
                       w.u64(r.time_us);
                       w.u32(r.line);
                       w.u8(static_cast<std::uint8_t>(r.edge));
                       w.text(r.chip);
                   },
                   [&](const MarkerRecord& r) {
                       w.u64(r.time_us);
                       w.text(r.text);
                   },
                   [&](const StreamRestartRecord& r) {
                       w.u64(r.time_us);
                       w.text(r.reason);
                   },
                   [&](const UnknownRecord& r) { w.bytes(r.payload); },
               },
               body);
}

// Parses a payload whose CRC matched; throws FormatError when it does not fit its layout.
RecordBody parse_payload(std::uint16_t type, std::uint16_t flags, std::span<const std::uint8_t> payload,
                         std::uint64_t base) {
    Reader r(payload, base, "record");
    switch (static_cast<RecordType>(type)) {
    case RecordType::RawBytes: {
        RawBytesRecord rec;
        rec.time_us = r.u64("raw-bytes time");
        rec.stream_offset = r.u64("raw-bytes stream offset");
        const std::uint8_t direction = r.u8("raw-bytes direction");
        if (direction > static_cast<std::uint8_t>(Direction::Sent))
            throw FormatError("raw-bytes direction " + std::to_string(direction) + " at byte " +
                              std::to_string(base + 16) + " of the record is neither 0 (received) nor 1 (sent)");
        rec.direction = static_cast<Direction>(direction);
        const auto rest = r.rest();
        rec.bytes.assign(rest.begin(), rest.end());
        return rec;
    }
    case RecordType::DecodedMessage: {
        DecodedMessageRecord rec;
        rec.host_time_us = r.u64("decoded-message host time");
        rec.stream_offset = r.u64("decoded-message stream offset");
        rec.seq = r.u16("decoded-message seq");
        const std::uint8_t msg_type = r.u8("decoded-message type");
        const protocol::PayloadStatus s = protocol::decode_payload(msg_type, r.rest(), rec.message);
        if (s != protocol::PayloadStatus::Ok)
            throw FormatError(std::string("decoded-message payload at byte ") + std::to_string(base + 19) +
                              " of the record (type " + protocol::type_name(msg_type) + ") does not decode: " +
                              protocol::status_name(s));
        return rec;
    }
    case RecordType::GpioEvent: {
        GpioEventRecord rec;
        rec.time_us = r.u64("gpio time");
        rec.line = r.u32("gpio line");
        const std::uint8_t edge = r.u8("gpio edge");
        if (edge > static_cast<std::uint8_t>(Edge::Rising))
            throw FormatError("gpio edge " + std::to_string(edge) + " at byte " + std::to_string(base + 12) +
                              " of the record is neither 0 (falling) nor 1 (rising)");
        rec.edge = static_cast<Edge>(edge);
        rec.chip = r.text(r.rest().size(), "gpio chip");
        return rec;
    }
    case RecordType::Marker: {
        MarkerRecord rec;
        rec.time_us = r.u64("marker time");
        rec.text = r.text(r.rest().size(), "marker text");
        return rec;
    }
    case RecordType::StreamRestart: {
        StreamRestartRecord rec;
        rec.time_us = r.u64("stream-restart time");
        rec.reason = r.text(r.rest().size(), "stream-restart reason");
        return rec;
    }
    }
    UnknownRecord rec;
    rec.type = type;
    rec.flags = flags;
    rec.payload.assign(payload.begin(), payload.end());
    return rec;
}

}  // namespace

const char* transport_name(Transport transport) {
    switch (transport) {
    case Transport::Unknown: return "unknown";
    case Transport::Serial: return "serial";
    case Transport::I2c: return "i2c";
    case Transport::Modbus: return "modbus";
    case Transport::Gpio: return "gpio";
    case Transport::Simulator: return "simulator";
    }
    return "unknown";
}

bool transport_has_byte_stream(Transport transport) {
    return transport != Transport::I2c && transport != Transport::Modbus && transport != Transport::Gpio;
}

std::optional<Transport> transport_from_name(const std::string& name) {
    for (std::uint8_t v = 0; v <= static_cast<std::uint8_t>(Transport::Simulator); ++v) {
        const auto t = static_cast<Transport>(v);
        if (name == transport_name(t)) return t;
    }
    return std::nullopt;
}

std::vector<std::uint8_t> board_message_types() {
    std::vector<std::uint8_t> types;
    for (auto t = static_cast<std::uint8_t>(protocol::MessageType::Hello);
         t <= static_cast<std::uint8_t>(protocol::MessageType::ConfigAck); ++t)
        types.push_back(t);
    return types;
}

const char* record_type_name(std::uint16_t type) {
    switch (static_cast<RecordType>(type)) {
    case RecordType::RawBytes: return "raw_bytes";
    case RecordType::DecodedMessage: return "decoded_message";
    case RecordType::GpioEvent: return "gpio_event";
    case RecordType::Marker: return "marker";
    case RecordType::StreamRestart: return "stream_restart";
    }
    return "unknown";
}

const char* check_name(RecordCheck check) {
    switch (check) {
    case RecordCheck::Ok: return "ok";
    case RecordCheck::NeedMore: return "incomplete record";
    case RecordCheck::BadSync: return "no sync marker";
    case RecordCheck::BadSize: return "payload size out of range";
    case RecordCheck::BadCrc: return "CRC mismatch";
    case RecordCheck::Malformed: return "malformed payload";
    }
    return "?";
}

std::optional<std::uint64_t> record_time_us(const RecordBody& body) {
    return std::visit(Overloaded{
                          [](const RawBytesRecord& r) -> std::optional<std::uint64_t> { return r.time_us; },
                          [](const DecodedMessageRecord& r) -> std::optional<std::uint64_t> {
                              return r.host_time_us;
                          },
                          [](const GpioEventRecord& r) -> std::optional<std::uint64_t> { return r.time_us; },
                          [](const MarkerRecord& r) -> std::optional<std::uint64_t> { return r.time_us; },
                          [](const StreamRestartRecord& r) -> std::optional<std::uint64_t> { return r.time_us; },
                          [](const UnknownRecord&) -> std::optional<std::uint64_t> { return std::nullopt; },
                      },
                      body);
}

std::uint16_t record_type_of(const RecordBody& body) {
    if (const auto* u = std::get_if<UnknownRecord>(&body)) return u->type;
    // The variant's alternatives follow RecordType's order 1..5.
    return static_cast<std::uint16_t>(body.index() + 1);
}

Bytes encode_header(const FileHeader& header) {
    check_header_text(header);
    if (header.decoded_types.size() > 0xFF)
        throw FormatError("at most 255 decoded message types fit the header");
    Bytes out;
    Writer w(out);
    w.bytes(kMagic);
    w.u16(kFormatMajor);
    w.u16(kFormatMinor);
    w.u32(0);  // header_size, patched below
    w.u64(static_cast<std::uint64_t>(header.created_unix_us));
    w.u64(header.created_monotonic_us);
    w.u8(static_cast<std::uint8_t>(header.transport));
    w.u8(header.protocol_major);
    w.u8(header.protocol_minor);
    w.u8(static_cast<std::uint8_t>(header.decoded_types.size()));
    w.u32(header.baud);
    w.bytes(header.decoded_types);
    w.short_text(header.device, "device");
    if (header.notes.size() > 0xFFFF) throw FormatError("at most 65535 notes fit the header");
    w.u16(static_cast<std::uint16_t>(header.notes.size()));
    for (const Note& note : header.notes) {
        w.short_text(note.key, "note key");
        w.short_text(note.value, "note value");
    }
    const std::size_t size = out.size() + 4;
    if (size > kMaxHeaderSize)
        throw FormatError("header of " + std::to_string(size) + " bytes is larger than the limit of " +
                          std::to_string(kMaxHeaderSize));
    bio::put_u32(out.data() + 12, static_cast<std::uint32_t>(size));
    w.u32(protocol::crc32c(out));
    return out;
}

FileHeader parse_header(std::span<const std::uint8_t> bytes) {
    // Identify the file before anything else, so a stranger file gets "not a recording" and a
    // cut-off recording gets "truncated".
    const std::size_t magic_seen = std::min(bytes.size(), kMagic.size());
    if (!std::equal(bytes.begin(), bytes.begin() + static_cast<std::ptrdiff_t>(magic_seen), kMagic.begin()))
        throw FormatError("not a Glint recording (the first 8 bytes are not \"GLINTREC\")");
    if (bytes.size() < kPreambleSize)
        throw FormatError("truncated header: the file ends at byte " + std::to_string(bytes.size()) +
                          ", inside the 16-byte preamble");
    FileHeader h;
    h.format_major = bio::get_u16(bytes.data() + 8);
    h.format_minor = bio::get_u16(bytes.data() + 10);
    h.header_size = bio::get_u32(bytes.data() + 12);
    if (h.format_major != kFormatMajor)
        throw FormatError("recording format " + std::to_string(h.format_major) + "." +
                          std::to_string(h.format_minor) + " (byte 8) is " +
                          (h.format_major > kFormatMajor ? "newer than" : "not readable by") +
                          " this reader (format " + std::to_string(kFormatMajor) + "." +
                          std::to_string(kFormatMinor) + ")");
    if (h.header_size < kMinHeaderSize || h.header_size > kMaxHeaderSize)
        throw FormatError("header size " + std::to_string(h.header_size) + " (byte 12) is outside " +
                          std::to_string(kMinHeaderSize) + ".." + std::to_string(kMaxHeaderSize));
    if (bytes.size() < h.header_size)
        throw FormatError("truncated header: the file ends at byte " + std::to_string(bytes.size()) +
                          ", inside the " + std::to_string(h.header_size) + "-byte header");
    const auto checked = bytes.first(h.header_size - 4);
    const std::uint32_t stored = bio::get_u32(bytes.data() + h.header_size - 4);
    const std::uint32_t computed = protocol::crc32c(checked);
    if (stored != computed)
        throw FormatError("header CRC mismatch at byte " + std::to_string(h.header_size - 4) + " (stored " +
                          hex32(stored) + ", computed " + hex32(computed) + ")");

    Reader r(checked, 0, "header");
    r.text(kPreambleSize, "preamble");
    h.created_unix_us = static_cast<std::int64_t>(r.u64("creation time"));
    h.created_monotonic_us = r.u64("creation monotonic time");
    h.transport = static_cast<Transport>(r.u8("transport"));
    h.protocol_major = r.u8("protocol major");
    h.protocol_minor = r.u8("protocol minor");
    const std::uint8_t type_count = r.u8("decoded type count");
    h.baud = r.u32("baud");
    for (std::uint8_t i = 0; i < type_count; ++i) h.decoded_types.push_back(r.u8("decoded type"));
    h.device = r.text(r.u16("device length"), "device");
    const std::uint16_t note_count = r.u16("note count");
    for (std::uint16_t i = 0; i < note_count; ++i) {
        Note note;
        note.key = r.text(r.u16("note key length"), "note key");
        note.value = r.text(r.u16("note value length"), "note value");
        h.notes.push_back(std::move(note));
    }
    // Bytes left before the CRC are fields of a newer minor version: ignored on purpose.
    return h;
}

Bytes encode_record(const RecordBody& body) {
    Bytes out(kRecordHeaderSize);
    encode_payload(body, out);
    const std::size_t payload_size = out.size() - kRecordHeaderSize;
    if (payload_size > kMaxRecordPayload)
        throw FormatError("record payload of " + std::to_string(payload_size) + " bytes exceeds the limit of " +
                          std::to_string(kMaxRecordPayload));
    const std::uint16_t flags = std::holds_alternative<UnknownRecord>(body) ? std::get<UnknownRecord>(body).flags : 0;
    std::copy(kRecordSync.begin(), kRecordSync.end(), out.begin());
    bio::put_u32(out.data() + 4, static_cast<std::uint32_t>(payload_size));
    bio::put_u16(out.data() + 8, record_type_of(body));
    bio::put_u16(out.data() + 10, flags);
    const auto all = std::span<const std::uint8_t>(out);
    bio::put_u32(out.data() + 12, record_crc(all.first(kRecordHeaderSize), all.subspan(kRecordHeaderSize)));
    return out;
}

RecordParse parse_record(std::span<const std::uint8_t> bytes) {
    RecordParse result;
    const std::size_t sync_seen = std::min(bytes.size(), kRecordSync.size());
    if (!std::equal(bytes.begin(), bytes.begin() + static_cast<std::ptrdiff_t>(sync_seen), kRecordSync.begin())) {
        result.check = RecordCheck::BadSync;
        return result;
    }
    if (bytes.size() < kRecordHeaderSize) {
        result.check = RecordCheck::NeedMore;
        return result;
    }
    const std::uint32_t payload_size = bio::get_u32(bytes.data() + 4);
    if (payload_size > kMaxRecordPayload) {
        result.check = RecordCheck::BadSize;
        return result;
    }
    result.size = kRecordHeaderSize + payload_size;
    if (bytes.size() < result.size) {
        result.check = RecordCheck::NeedMore;
        return result;
    }
    const auto header = bytes.first(kRecordHeaderSize);
    const auto payload = bytes.subspan(kRecordHeaderSize, payload_size);
    if (bio::get_u32(bytes.data() + 12) != record_crc(header, payload)) {
        result.check = RecordCheck::BadCrc;
        return result;
    }
    try {
        // Offsets in messages are relative to the record's start; the reader adds its position.
        result.body = parse_payload(bio::get_u16(bytes.data() + 8), bio::get_u16(bytes.data() + 10), payload,
                                    kRecordHeaderSize);
        result.check = RecordCheck::Ok;
    } catch (const FormatError& e) {
        result.check = RecordCheck::Malformed;
        result.detail = e.what();
    }
    return result;
}

}  // namespace glint::recording
