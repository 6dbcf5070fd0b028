#include "appliance/capture/kiosk_session.hpp"

#include <cctype>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <set>
#include <sstream>

#include "appliance/core/errors.hpp"
#include "appliance/core/rotation.hpp"
#include "appliance/core/strict_number.hpp"

namespace glint::capture {

namespace fs = std::filesystem;

namespace {

// A quaternion read from a file is accepted as a rotation only this close to unit length (the
// files are written with 12 decimals); anything else is a mistake, not rounding.
constexpr double kUnitTolerance = 1e-6;

struct CsvRow {
    int line = 0;
    std::vector<std::string> fields;
};

// The rows after the header (which must equal `header`), each with exactly `columns` fields.
// The same rules as session.cpp's frame list: "FILE:LINE: why" for anything else.
std::vector<CsvRow> read_csv(const fs::path& p, const std::string& header, std::size_t columns) {
    std::ifstream in(p);
    if (!in) throw InputError(p.string() + ": cannot be read");
    std::string line;
    if (!std::getline(in, line) || line != header)
        throw InputError(p.string() + ":1: the header must be '" + header + "'");
    std::vector<CsvRow> rows;
    int number = 1;
    while (std::getline(in, line)) {
        ++number;
        if (line.empty()) continue;
        CsvRow row{number, {}};
        std::size_t start = 0;
        for (;;) {
            const std::size_t comma = line.find(',', start);
            row.fields.push_back(line.substr(start, comma == std::string::npos ? std::string::npos : comma - start));
            if (comma == std::string::npos) break;
            start = comma + 1;
        }
        if (row.fields.size() != columns)
            throw InputError(p.string() + ":" + std::to_string(number) + ": " + std::to_string(row.fields.size()) +
                             " fields, expected " + std::to_string(columns));
        rows.push_back(std::move(row));
    }
    return rows;
}

// Event sources and names are words: letters, digits, '_' and '-'.
bool is_word(const std::string& s) {
    if (s.empty()) return false;
    for (const char c : s)
        if (!(std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '-')) return false;
    return true;
}

glm::dquat checked_rotation(double w, double x, double y, double z, const std::string& where) {
    const double n = std::sqrt(w * w + x * x + y * y + z * z);
    if (!(std::abs(n - 1) <= kUnitTolerance))
        throw InputError(where + ": the quaternion's length is " + std::to_string(n) + ", not 1");
    return unit_rotation(glm::dquat(w, x, y, z));
}

std::string read_text(const fs::path& p) {
    std::ifstream in(p);
    if (!in) throw InputError(p.string() + ": cannot be read");
    std::stringstream s;
    s << in.rdbuf();
    return s.str();
}

}  // namespace

const KioskPhase* KioskSessionInfo::phase(const std::string& name) const {
    for (const KioskPhase& p : phases)
        if (p.name == name) return &p;
    return nullptr;
}

std::string session_events_csv_header() { return "t_ns,source,event"; }

std::string session_events_csv_line(const SessionEvent& e) {
    return std::to_string(e.t_ns) + "," + e.source + "," + e.event;
}

std::string truth_board_csv_header() { return "index,t_ns,qw,qx,qy,qz,tx,ty,tz"; }

std::string truth_board_csv_line(const TruthBoardPose& p) {
    char buf[256];
    std::snprintf(buf, sizeof buf, "%llu,%lld,%.12f,%.12f,%.12f,%.12f,%.9f,%.9f,%.9f",
                  static_cast<unsigned long long>(p.index), static_cast<long long>(p.t_ns), p.camera_from_board.w,
                  p.camera_from_board.x, p.camera_from_board.y, p.camera_from_board.z, p.t_m.x, p.t_m.y, p.t_m.z);
    return buf;
}

std::string kiosk_json(const KioskSessionInfo& info) {
    nlohmann::ordered_json j;
    j["format"] = "glint-kiosk-session";
    j["version"] = kKioskSessionVersion;
    j["phases"] = nlohmann::ordered_json::array();
    for (const KioskPhase& p : info.phases)
        j["phases"].push_back({{"name", p.name}, {"start_ns", p.start_ns}, {"end_ns", p.end_ns}});
    nlohmann::ordered_json board;
    try {
        board = nlohmann::ordered_json::parse(info.board_json);
    } catch (const nlohmann::json::exception& e) {
        throw InputError(std::string("kiosk.json: key 'board': not JSON (") + e.what() + ")");
    }
    if (!board.is_object()) throw InputError("kiosk.json: key 'board': must be a JSON object");
    j["board"] = board;
    j["table_height_m"] = info.table_height_m;
    // + 0.0 turns a negative zero (from a rotation's arithmetic) into "0.0" rather than "-0.0".
    const glm::dquat& q = info.world_from_board;
    const glm::dvec3& t = info.world_board_t;
    j["world_from_board"] = {{"w", q.w + 0.0}, {"x", q.x + 0.0}, {"y", q.y + 0.0}, {"z", q.z + 0.0},
                             {"t", {t.x + 0.0, t.y + 0.0, t.z + 0.0}}};
    return j.dump(2) + "\n";
}

std::vector<SessionEvent> load_session_events(const Session& s) {
    const fs::path p = s.dir / "events.csv";
    if (!fs::exists(p)) return {};
    std::vector<SessionEvent> events;
    for (const CsvRow& row : read_csv(p, session_events_csv_header(), 3)) {
        const std::string where = p.string() + ":" + std::to_string(row.line);
        SessionEvent e;
        e.t_ns = parse_int(row.fields[0], where + ": t_ns");
        e.source = row.fields[1];
        e.event = row.fields[2];
        if (!is_word(e.source)) throw InputError(where + ": source '" + e.source + "' is not a word (letters, digits, _ -)");
        if (!is_word(e.event)) throw InputError(where + ": event '" + e.event + "' is not a word (letters, digits, _ -)");
        if (!events.empty() && e.t_ns < events.back().t_ns) throw InputError(where + ": t_ns: event times must not decrease");
        events.push_back(std::move(e));
    }
    return events;
}

std::optional<KioskSessionInfo> load_kiosk_info(const Session& s) {
    const fs::path p = s.dir / "kiosk.json";
    if (!fs::exists(p)) return std::nullopt;
    const std::string file = p.string();
    nlohmann::json j;
    try {
        j = nlohmann::json::parse(read_text(p));
    } catch (const nlohmann::json::exception& e) {  // parse_error, and out_of_range for a number beyond double's range
        throw InputError(file + ": not valid JSON (" + e.what() + ")");
    }
    const auto key_error = [&](const std::string& key, const std::string& why) {
        return InputError(file + ": key '" + key + "': " + why);
    };
    if (!j.is_object()) throw InputError(file + ": must be a JSON object");
    static const std::set<std::string> known = {"format", "version", "phases", "board", "table_height_m",
                                                "world_from_board"};
    for (const auto& [key, value] : j.items())
        if (!known.count(key))
            throw key_error(key, "unknown key (known: format, version, phases, board, table_height_m, world_from_board)");
    for (const char* key : {"format", "version", "phases", "board", "table_height_m", "world_from_board"})
        if (!j.contains(key)) throw key_error(key, "missing");
    if (!j["format"].is_string() || j["format"].get<std::string>() != "glint-kiosk-session")
        throw key_error("format", "must be \"glint-kiosk-session\"");
    if (!j["version"].is_number_integer() || j["version"].get<long long>() != kKioskSessionVersion)
        throw key_error("version", "this build reads version " + std::to_string(kKioskSessionVersion));
    // A finite number (or a whole number for times) at `key` of object `o`.
    const auto number = [&](const nlohmann::json& o, const std::string& key, const std::string& path) {
        if (!o.contains(key)) throw key_error(path, "missing");
        if (!o[key].is_number() || !std::isfinite(o[key].get<double>())) throw key_error(path, "must be a number");
        return o[key].get<double>();
    };
    const auto whole = [&](const nlohmann::json& o, const std::string& key, const std::string& path) {
        if (!o.contains(key)) throw key_error(path, "missing");
        if (!o[key].is_number_integer()) throw key_error(path, "must be a whole number of nanoseconds");
        return o[key].get<std::int64_t>();
    };

    KioskSessionInfo info;
    const nlohmann::json& phases = j["phases"];
    if (!phases.is_array() || phases.empty()) throw key_error("phases", "must be a non-empty array");
    for (std::size_t i = 0; i < phases.size(); ++i) {
        const std::string at = "phases[" + std::to_string(i) + "]";
        const nlohmann::json& o = phases[i];
        if (!o.is_object()) throw key_error(at, "must be an object {\"name\", \"start_ns\", \"end_ns\"}");
        for (const auto& [key, value] : o.items())
            if (key != "name" && key != "start_ns" && key != "end_ns")
                throw key_error(at + "." + key, "unknown key (known: name, start_ns, end_ns)");
        if (!o.contains("name") || !o["name"].is_string() || o["name"].get<std::string>().empty())
            throw key_error(at + ".name", "must be a non-empty string");
        KioskPhase phase;
        phase.name = o["name"].get<std::string>();
        phase.start_ns = whole(o, "start_ns", at + ".start_ns");
        phase.end_ns = whole(o, "end_ns", at + ".end_ns");
        if (phase.end_ns <= phase.start_ns) throw key_error(at + ".end_ns", "must be after start_ns");
        if (info.phase(phase.name)) throw key_error(at + ".name", "phase '" + phase.name + "' appears twice");
        if (!info.phases.empty() && phase.start_ns < info.phases.back().end_ns)
            throw key_error(at + ".start_ns", "the phases must be in time order, without overlap");
        info.phases.push_back(std::move(phase));
    }
    if (!j["board"].is_object()) throw key_error("board", "must be a JSON object (the board file's keys)");
    info.board_json = j["board"].dump();
    info.table_height_m = number(j, "table_height_m", "table_height_m");
    if (!(info.table_height_m >= 0 && info.table_height_m <= 10)) throw key_error("table_height_m", "must be in 0..10 metres");
    const nlohmann::json& wb = j["world_from_board"];
    if (!wb.is_object()) throw key_error("world_from_board", "must be an object {\"w\", \"x\", \"y\", \"z\", \"t\"}");
    for (const auto& [key, value] : wb.items())
        if (key != "w" && key != "x" && key != "y" && key != "z" && key != "t")
            throw key_error("world_from_board." + key, "unknown key (known: w, x, y, z, t)");
    const double w = number(wb, "w", "world_from_board.w"), x = number(wb, "x", "world_from_board.x"),
                 y = number(wb, "y", "world_from_board.y"), z = number(wb, "z", "world_from_board.z");
    info.world_from_board = checked_rotation(w, x, y, z, file + ": key 'world_from_board'");
    if (!wb.contains("t") || !wb["t"].is_array() || wb["t"].size() != 3)
        throw key_error("world_from_board.t", "must be an array of 3 numbers (metres)");
    for (int k = 0; k < 3; ++k) {
        const nlohmann::json& v = wb["t"][std::size_t(k)];
        if (!v.is_number() || !std::isfinite(v.get<double>()))
            throw key_error("world_from_board.t", "must be an array of 3 numbers (metres)");
        info.world_board_t[k] = v.get<double>();
    }
    return info;
}

std::vector<TruthBoardPose> load_truth_board_poses(const Session& s) {
    const fs::path p = s.dir / "truth" / "board.csv";
    if (!fs::exists(p)) return {};
    std::map<std::uint64_t, std::int64_t> frame_times;
    for (const FrameRecord& r : s.frames) frame_times[r.index] = r.t_ns;
    std::vector<TruthBoardPose> poses;
    for (const CsvRow& row : read_csv(p, truth_board_csv_header(), 9)) {
        const std::string where = p.string() + ":" + std::to_string(row.line);
        const auto& f = row.fields;
        TruthBoardPose t;
        const std::int64_t index = parse_int(f[0], where + ": index");
        if (index < 0) throw InputError(where + ": index must not be negative");
        t.index = std::uint64_t(index);
        t.t_ns = parse_int(f[1], where + ": t_ns");
        const auto frame = frame_times.find(t.index);
        if (frame == frame_times.end())
            throw InputError(where + ": index " + std::to_string(t.index) + " is not a frame of frames.csv");
        if (frame->second != t.t_ns) throw InputError(where + ": t_ns differs from the frame's in frames.csv");
        if (!poses.empty() && t.t_ns <= poses.back().t_ns) throw InputError(where + ": t_ns: times must increase");
        t.camera_from_board =
            checked_rotation(parse_double(f[2], where + ": qw"), parse_double(f[3], where + ": qx"),
                             parse_double(f[4], where + ": qy"), parse_double(f[5], where + ": qz"), where);
        t.t_m = {parse_double(f[6], where + ": tx"), parse_double(f[7], where + ": ty"),
                 parse_double(f[8], where + ": tz")};
        poses.push_back(t);
    }
    return poses;
}

}  // namespace glint::capture
