#include "appliance/capture/session.hpp"

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "appliance/capture/calibration_io.hpp"
#include "appliance/core/errors.hpp"
#include "appliance/core/strict_number.hpp"

namespace glint::capture {

namespace fs = std::filesystem;

namespace {

std::string read_text(const fs::path& p, const char* what) {
    std::ifstream in(p);
    if (!in) throw InputError(p.string() + ": cannot open the " + what);
    std::stringstream s;
    s << in.rdbuf();
    return s.str();
}

std::vector<std::string> split_csv(const std::string& line) {
    std::vector<std::string> out;
    std::string field;
    std::stringstream s(line);
    while (std::getline(s, field, ',')) out.push_back(field);
    if (!line.empty() && line.back() == ',') out.emplace_back();
    return out;
}

// A number as an error message shows it (frames_csv_line writes exposures with %.9g).
std::string csv_number(double v) {
    char buf[32];
    std::snprintf(buf, sizeof buf, "%.9g", v);
    return buf;
}

// Lines of a CSV file after its header, which must equal `header`.
std::vector<std::pair<int, std::vector<std::string>>> read_csv(const fs::path& p, const std::string& header,
                                                               std::size_t columns, const char* what) {
    std::ifstream in(p);
    if (!in) throw InputError(p.string() + ": cannot open the " + what);
    std::string line;
    // Lines ended CRLF (a file saved on Windows) read as LF: the header's '\r' made "the header
    // must be '...'" show the very header the file has.
    const auto next_line = [&] {
        if (!std::getline(in, line)) return false;
        if (!line.empty() && line.back() == '\r') line.pop_back();
        return true;
    };
    if (!next_line() || line != header) throw InputError(p.string() + ":1: the header must be '" + header + "'");
    std::vector<std::pair<int, std::vector<std::string>>> rows;
    int number = 1;
    while (next_line()) {
        ++number;
        if (line.empty()) continue;
        std::vector<std::string> f = split_csv(line);
        if (f.size() != columns)
            throw InputError(p.string() + ":" + std::to_string(number) + ": " + std::to_string(f.size()) +
                             " fields, expected " + std::to_string(columns));
        rows.emplace_back(number, std::move(f));
    }
    return rows;
}

}  // namespace

std::string frames_csv_header() { return "index,t_ns,exposure_s,analogue_gain,digital_gain,file"; }

std::string frames_csv_line(const FrameRecord& r) {
    char buf[160];
    std::snprintf(buf, sizeof buf, "%llu,%lld,%.9g,%.6g,%.6g,", static_cast<unsigned long long>(r.index),
                  static_cast<long long>(r.t_ns), r.exposure_s, r.analogue_gain, r.digital_gain);
    return buf + r.file;
}

std::string camera_poses_csv_header() { return "index,t_ns,w,x,y,z"; }

std::string camera_poses_csv_line(const TruthPose& p) {
    char buf[160];
    std::snprintf(buf, sizeof buf, "%llu,%lld,%.12f,%.12f,%.12f,%.12f", static_cast<unsigned long long>(p.index),
                  static_cast<long long>(p.t_ns), p.world_from_camera.w, p.world_from_camera.x, p.world_from_camera.y,
                  p.world_from_camera.z);
    return buf;
}

std::string session_json(const std::string& created_by) {
    nlohmann::json j;
    j["format"] = "glint-session";
    j["version"] = kSessionVersion;
    j["calibration"] = "calibration.json";
    j["frames"] = "frames.csv";
    j["sensors"] = "sensors.glrec";
    j["created_by"] = created_by;
    return j.dump(2) + "\n";
}

Session open_session(const fs::path& dir) {
    if (!fs::is_directory(dir)) throw InputError(dir.string() + ": no such session directory");
    Session s;
    s.dir = dir;
    const fs::path meta = dir / "session.json";
    nlohmann::json j;
    try {
        j = nlohmann::json::parse(read_text(meta, "session description"));
    } catch (const nlohmann::json::exception& e) {  // parse_error, and out_of_range for a number beyond double's range
        throw InputError(meta.string() + ": not valid JSON (" + e.what() + ")");
    }
    // Not j.value("format", ""): it throws nlohmann's type_error when "format" is not a string.
    if (!j.is_object() || !j.contains("format") || !j["format"].is_string() || j["format"] != "glint-session")
        throw InputError(meta.string() + ": key 'format': not a Glint session");
    if (!j.contains("version") || !j["version"].is_number_integer() || j["version"].get<int>() != kSessionVersion)
        throw InputError(meta.string() + ": key 'version': this build reads version " +
                         std::to_string(kSessionVersion));
    // A session names its own files: a path out of it (absolute, or through ..) could read any file
    // on the appliance, or /dev/zero for ever.
    const auto inside = [&](const char* key) {
        const std::string name = j[key].get<std::string>();
        if (name.empty() || fs::path(name).is_absolute() || name.find("..") != std::string::npos)
            throw InputError(meta.string() + ": key '" + std::string(key) + "': '" + name +
                             "' is not a relative path inside the session");
    };
    for (const char* key : {"calibration", "frames"}) {
        if (!j.contains(key) || !j[key].is_string())
            throw InputError(meta.string() + ": key '" + std::string(key) + "': missing");
        inside(key);
    }
    if (j.contains("sensors") && j["sensors"].is_string()) inside("sensors");
    s.calibration = load_calibration(dir / j["calibration"].get<std::string>());
    if (j.contains("sensors") && j["sensors"].is_string() && fs::exists(dir / j["sensors"].get<std::string>()))
        s.sensors = dir / j["sensors"].get<std::string>();
    const fs::path frames = dir / j["frames"].get<std::string>();
    for (const auto& [line, f] : read_csv(frames, frames_csv_header(), 6, "frame list")) {
        const std::string where = frames.string() + ":" + std::to_string(line);
        FrameRecord r;
        r.index = std::uint64_t(parse_int(f[0], where));
        r.t_ns = parse_int(f[1], where);
        r.exposure_s = parse_double(f[2], where);
        r.analogue_gain = parse_double(f[3], where);
        r.digital_gain = parse_double(f[4], where);
        r.file = f[5];
        if (!(r.exposure_s > 0) || !(r.analogue_gain > 0) || !(r.digital_gain > 0))
            throw InputError(where + ": exposure and gains must be positive");
        // A frame's radiance is its code over exposure x gain: an exposure of 1e300 s made every
        // texel it saw 0 and printed a motion blur of 1e300 pixels; one of 1e-300 s a map of 1e290.
        if (r.exposure_s < kMinFrameExposureS || r.exposure_s > kMaxFrameExposureS)
            throw InputError(where + ": exposure " + csv_number(r.exposure_s) + " s is outside what a camera takes (" +
                             csv_number(kMinFrameExposureS) + " to " + csv_number(kMaxFrameExposureS) + " s)");
        for (const double g : {r.analogue_gain, r.digital_gain})
            if (g < kMinFrameGain || g > kMaxFrameGain)
                throw InputError(where + ": gain " + csv_number(g) + " is outside what a camera sets (" +
                                 csv_number(kMinFrameGain) + " to " + csv_number(kMaxFrameGain) + ")");
        if (r.file.empty() || fs::path(r.file).is_absolute() || r.file.find("..") != std::string::npos)
            throw InputError(where + ": frame file must be a relative path inside the session");
        if (!s.frames.empty() && r.t_ns <= s.frames.back().t_ns)
            throw InputError(where + ": frame times must increase");
        // The index is the frame's name in truth/camera.csv and in --orientations-out: a repeated
        // one compared a frame with its neighbour's true pose (22 degrees off at 35 deg/s).
        if (!s.frames.empty() && r.index <= s.frames.back().index)
            throw InputError(where + ": frame indices must increase (" + std::to_string(r.index) + " after " +
                             std::to_string(s.frames.back().index) + ")");
        // A replay waits out the gap between frames (on a virtual clock too, in steps): a time
        // off by years kept `glint capture` busy for minutes.
        // (Unsigned: the times increase, so the difference is right even where a signed one
        // would overflow.)
        constexpr std::uint64_t kMaxGapNs = 3'600'000'000'000;
        const std::uint64_t gap = s.frames.empty() ? 0 : std::uint64_t(r.t_ns) - std::uint64_t(s.frames.back().t_ns);
        if (gap > kMaxGapNs)
            throw InputError(where + ": the frame comes " + std::to_string(gap / 1'000'000'000) +
                             " s after the one before it; a session has no gap over an hour");
        s.frames.push_back(std::move(r));
    }
    if (s.frames.empty()) throw InputError(frames.string() + ": the session has no frames");
    s.has_truth = fs::exists(dir / "truth" / "camera.csv");
    return s;
}

CameraFrame load_frame(const Session& session, const FrameRecord& r) {
    const fs::path p = session.dir / r.file;
    cv::Mat bgr = cv::imread(p.string(), cv::IMREAD_COLOR);
    if (bgr.empty()) throw InputError(p.string() + ": missing or not a readable image");
    CameraFrame f;
    cv::cvtColor(bgr, f.rgb, cv::COLOR_BGR2RGB);
    f.t_ns = r.t_ns;
    f.exposure_s = r.exposure_s;
    f.analogue_gain = r.analogue_gain;
    f.digital_gain = r.digital_gain;
    f.sequence = r.index;
    return f;
}

void check_frame_size(const Session& session, const FrameRecord& record, const CameraFrame& frame) {
    const Intrinsics& k = session.calibration.intrinsics;
    if (!frame.is(k.width, k.height))
        throw InputError((session.dir / record.file).string() + ": the image is " + std::to_string(frame.rgb.cols) + "x" +
                         std::to_string(frame.rgb.rows) + ", the session's calibration (" +
                         (session.dir / "calibration.json").string() + ") is for " + std::to_string(k.width) + "x" +
                         std::to_string(k.height));
}

std::vector<TruthPose> load_truth_poses(const Session& session) {
    const fs::path p = session.dir / "truth" / "camera.csv";
    std::vector<TruthPose> poses;
    for (const auto& [line, f] : read_csv(p, camera_poses_csv_header(), 6, "true camera orientations")) {
        const std::string where = p.string() + ":" + std::to_string(line);
        TruthPose t;
        t.index = std::uint64_t(parse_int(f[0], where));
        t.t_ns = parse_int(f[1], where);
        t.world_from_camera = unit_rotation(glm::dquat(parse_double(f[2], where), parse_double(f[3], where),
                                                       parse_double(f[4], where), parse_double(f[5], where)));
        poses.push_back(t);
    }
    return poses;
}

fs::path truth_env_path(const Session& session) { return session.dir / "truth" / "env.exr"; }

}  // namespace glint::capture
