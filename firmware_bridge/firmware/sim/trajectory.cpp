// Trajectory files, built-in motions and interpolation: see trajectory.hpp.
#include "firmware_bridge/firmware/sim/trajectory.hpp"

#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <numbers>
#include <sstream>
#include <stdexcept>

namespace glint::firmware::sim {
namespace {

constexpr double kDeg = std::numbers::pi / 180.0;

[[noreturn]] void fail(const std::string& source, std::size_t line, const std::string& what) {
    throw std::runtime_error(source + ":" + std::to_string(line) + ": " + what);
}

std::vector<std::string> split_fields(const std::string& line) {
    std::vector<std::string> fields;
    std::string current;
    for (char c : line) {
        if (c == ',' || c == ' ' || c == '\t' || c == '\r') {
            if (!current.empty()) fields.push_back(current);
            current.clear();
        } else {
            current += c;
        }
    }
    if (!current.empty()) fields.push_back(current);
    return fields;
}

double parse_number(const std::string& text, const std::string& source, std::size_t line,
                    std::size_t column) {
    errno = 0;
    char* end = nullptr;
    const double v = std::strtod(text.c_str(), &end);
    if (end == text.c_str() || *end != '\0' || errno == ERANGE || !std::isfinite(v)) {
        fail(source, line, "field " + std::to_string(column) + " '" + text + "' is not a finite number");
    }
    return v;
}

}  // namespace

Quatd quat_from_ypr_deg(double yaw_deg, double pitch_deg, double roll_deg) {
    return Quatd::from_axis_angle({0, 1, 0}, yaw_deg * kDeg) *
           Quatd::from_axis_angle({1, 0, 0}, pitch_deg * kDeg) *
           Quatd::from_axis_angle({0, 0, 1}, roll_deg * kDeg);
}

Trajectory::Trajectory(std::vector<TrajectorySample> samples) : samples_(std::move(samples)) {
    if (samples_.empty()) throw std::invalid_argument("trajectory has no samples");
    if (samples_.front().time_us != 0) throw std::invalid_argument("trajectory must start at time 0");
    for (std::size_t i = 1; i < samples_.size(); ++i) {
        if (samples_[i].time_us <= samples_[i - 1].time_us) {
            throw std::invalid_argument("trajectory times must increase strictly");
        }
    }
    for (auto& s : samples_) s.world_from_sensor = normalized(s.world_from_sensor);
}

Trajectory Trajectory::parse(const std::string& text, const std::string& source) {
    // Seconds: the fixed format (firmware/README.md, "Trajectory files") and of `glint simulate` (no format line): lines of
    // t_seconds,w,x,y,z. The two formats with a format line take times in microseconds.
    enum class Format { Unknown, Quaternion, YprDeg, Seconds } format = Format::Unknown;
    std::vector<TrajectorySample> samples;
    std::istringstream in(text);
    std::string line;
    std::size_t line_no = 0;
    while (std::getline(in, line)) {
        ++line_no;
        const std::size_t hash = line.find('#');
        if (hash != std::string::npos) line.resize(hash);
        const std::vector<std::string> fields = split_fields(line);
        if (fields.empty()) continue;
        if (format == Format::Unknown) {
            if (fields.size() == 2 && fields[0] == "format" && fields[1] == "quaternion") {
                format = Format::Quaternion;
            } else if (fields.size() == 2 && fields[0] == "format" && fields[1] == "ypr_deg") {
                format = Format::YprDeg;
            } else if (fields.size() == 5) {
                format = Format::Seconds;  // this line is the first sample
            } else {
                fail(source, line_no,
                     "expected samples t_seconds,w,x,y,z (or a line 'format quaternion' / 'format ypr_deg')");
            }
            if (format != Format::Seconds) continue;
        }
        const std::size_t expected = format == Format::YprDeg ? 4 : 5;
        const char* layout = format == Format::Quaternion ? "time_us, w, x, y, z"
                             : format == Format::YprDeg   ? "time_us, yaw, pitch, roll"
                                                          : "t_seconds, w, x, y, z";
        if (fields.size() != expected) {
            fail(source, line_no, "expected " + std::to_string(expected) + " fields (" + layout + "), got " +
                                      std::to_string(fields.size()));
        }
        double values[5] = {};
        for (std::size_t i = 0; i < expected; ++i) values[i] = parse_number(fields[i], source, line_no, i + 1);
        if (format == Format::Seconds) {
            if (values[0] < 0 || values[0] > 1e9) fail(source, line_no, "t_seconds '" + fields[0] + "' must be >= 0");
            values[0] = std::round(values[0] * 1e6);
        } else if (values[0] < 0 || values[0] > 1e15 || values[0] != std::floor(values[0])) {
            fail(source, line_no, "time_us '" + fields[0] + "' is not a whole number of microseconds >= 0");
        }
        TrajectorySample s;
        s.time_us = static_cast<std::uint64_t>(values[0]);
        if (samples.empty() && s.time_us != 0) fail(source, line_no, "the first sample must be at time 0");
        if (!samples.empty() && s.time_us <= samples.back().time_us) {
            // In the file's own unit (a seconds file was told of microseconds before).
            const std::string previous = format == Format::Seconds
                                             ? std::to_string(double(samples.back().time_us) * 1e-6) + " s"
                                             : std::to_string(samples.back().time_us) + " us";
            fail(source, line_no,
                 std::string(format == Format::Seconds ? "t_seconds " : "time_us ") + fields[0] +
                     " does not increase (previous " + previous + ")");
        }
        if (format != Format::YprDeg) {
            s.world_from_sensor = {values[1], values[2], values[3], values[4]};
            const double n = norm(s.world_from_sensor);
            if (std::fabs(n - 1.0) > 0.01) {
                fail(source, line_no, "quaternion norm " + std::to_string(n) + " is not 1 (+-0.01)");
            }
        } else {
            s.world_from_sensor = quat_from_ypr_deg(values[1], values[2], values[3]);
        }
        samples.push_back(s);
    }
    if (format == Format::Unknown) fail(source, line_no, "no samples: the file is empty");
    if (samples.empty()) fail(source, line_no, "no samples after the format line");
    return Trajectory(std::move(samples));
}

Trajectory Trajectory::load(const std::string& path) {
    std::ifstream file(path, std::ios::binary);
    if (!file) throw std::runtime_error(path + ": cannot open trajectory file");
    std::ostringstream text;
    text << file.rdbuf();
    if (file.bad()) throw std::runtime_error(path + ": read error");
    return parse(text.str(), path);
}

std::vector<std::string> Trajectory::builtin_names() { return {"static", "yaw-sweep", "tumble", "kiosk"}; }

// Built-ins are sampled every 10 ms from smooth functions of time.
Trajectory Trajectory::builtin(const std::string& name) {
    using Fn = Quatd (*)(double);
    Fn fn = nullptr;
    double period_s = 60;
    if (name == "static") {
        // Tilted and turned, so no axis is trivially aligned.
        fn = [](double) { return quat_from_ypr_deg(30, 10, -5); };
    } else if (name == "yaw-sweep") {
        // Looking around: +-90 deg of yaw with a 20 s period, slight pitch.
        fn = [](double t) { return quat_from_ypr_deg(90 * std::sin(2 * std::numbers::pi * t / 20), 5, 0); };
        period_s = 20;
    } else if (name == "tumble") {
        // Every axis moving at once, up to ~60 deg/s; all three periods divide 60 s.
        fn = [](double t) {
            const double w = 2 * std::numbers::pi / 60;
            return quat_from_ypr_deg(60 * t, 40 * std::sin(5 * w * t), 30 * std::sin(8 * w * t + 1));
        };
    } else if (name == "kiosk") {
        // A visitor handling the device: rest 5 s, look left and right, tilt, rest again.
        fn = [](double t) {
            const double phase = std::fmod(t, 30.0);
            if (phase < 5) return quat_from_ypr_deg(0, 0, 0);
            const double s = (phase - 5) / 25 * 2 * std::numbers::pi;
            return quat_from_ypr_deg(70 * std::sin(s), 20 * std::sin(2 * s), 8 * std::sin(3 * s));
        };
        period_s = 30;
    } else {
        std::string names;
        for (const auto& n : builtin_names()) names += (names.empty() ? "" : ", ") + n;
        throw std::runtime_error("unknown built-in trajectory '" + name + "' (known: " + names + ")");
    }
    std::vector<TrajectorySample> samples;
    const std::uint64_t step_us = 10'000;
    const auto period_us = static_cast<std::uint64_t>(period_s * 1e6);
    for (std::uint64_t t = 0; t <= period_us; t += step_us) {
        samples.push_back({t, fn(static_cast<double>(t) * 1e-6)});
    }
    Trajectory trajectory(std::move(samples));
    trajectory.set_loop(true);
    return trajectory;
}

MotionState Trajectory::at(std::uint64_t time_us) const {
    // A looping trajectory's period boundary after the first is the end of its last segment.
    const bool period_end = loop_ && time_us > 0 && time_us % samples_.back().time_us == 0;
    if (loop_) time_us %= samples_.back().time_us;
    MotionState state;
    if (time_us >= samples_.back().time_us || samples_.size() == 1) {
        state.world_from_sensor = samples_.back().world_from_sensor;
        return state;
    }
    // Binary search for the segment [i, i+1] holding time_us.
    std::size_t lo = 0, hi = samples_.size() - 1;
    while (hi - lo > 1) {
        const std::size_t mid = (lo + hi) / 2;
        (samples_[mid].time_us <= time_us ? lo : hi) = mid;
    }
    const TrajectorySample& a = samples_[lo];
    const TrajectorySample& b = samples_[hi];
    const double span_s = static_cast<double>(b.time_us - a.time_us) * 1e-6;
    const double t = static_cast<double>(time_us - a.time_us) * 1e-6 / span_s;
    state.world_from_sensor = slerp(a.world_from_sensor, b.world_from_sensor, t);
    // Slerp turns at a constant rate about a fixed axis in the sensor frame: the rotation
    // a* b expressed in a's frame, divided by the segment's duration. At a sample's own time
    // the rate is that of the segment ending there: a gyro's reading is an average over the
    // moments before it (its low-pass filter), never after, and a board that samples on the
    // trajectory's grid integrates each reading over the interval before it. The segment
    // after it made such a board's orientation one sample early (2.5-5 ms, 2026-12-08).
    std::size_t from = lo;  // the segment holding the time
    if (time_us == a.time_us && lo > 0) from = lo - 1;
    if (period_end) from = samples_.size() - 2;
    const TrajectorySample& ra = samples_[from];
    const TrajectorySample& rb = samples_[from + 1];
    const double rate_span_s = static_cast<double>(rb.time_us - ra.time_us) * 1e-6;
    state.angular_rate_rad_s = (1.0 / rate_span_s) * log_map(ra.world_from_sensor.conj() *
                                                             same_hemisphere(rb.world_from_sensor, ra.world_from_sensor));
    return state;
}

}  // namespace glint::firmware::sim
