#include "appliance/app/session_recorder.hpp"

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "appliance/capture/calibration_io.hpp"
#include "appliance/capture/session.hpp"
#include "appliance/core/atomic_file.hpp"
#include "appliance/core/errors.hpp"
#include "firmware_bridge/recording/format.hpp"

namespace glint::app {
namespace fs = std::filesystem;

namespace {
std::FILE* open_for_lines(const fs::path& path, const std::string& header) {
    std::FILE* f = std::fopen(path.c_str(), "wx");  // x: never over an existing file
    if (!f) throw InputError("--record: cannot create " + path.string() + ": " + std::strerror(errno));
    std::fputs(header.c_str(), f);
    std::fputc('\n', f);
    std::fflush(f);
    return f;
}
}  // namespace

SessionRecorder::SessionRecorder(const fs::path& dir, const capture::CameraCalibration& calibration,
                                 const host::SourceSpec& sensor, recording::Clock& clock)
    : dir_(dir) {
    if (fs::exists(dir)) throw InputError("--record " + dir.string() + ": exists (a recording is never written over)");
    std::error_code ec;
    fs::create_directories(dir / "frames", ec);
    if (ec) throw InputError("--record " + dir.string() + ": cannot create it: " + ec.message());
    write_text_atomically(dir / "session.json", capture::session_json("glint run --record"));
    capture::save_calibration(dir / "calibration.json", calibration);
    frames_csv_ = open_for_lines(dir / "frames.csv", capture::frames_csv_header());
    events_csv_ = open_for_lines(dir / "events.csv", capture::session_events_csv_header());
    if (host::recording_options_for(sensor)) {
        try {
            sensors_ = std::make_unique<host::SensorRecording>((dir / "sensors.glrec").string(), sensor, clock);
        } catch (const std::exception& e) {
            throw InputError(std::string("--record: ") + e.what());
        }
    }
}

SessionRecorder::~SessionRecorder() { close(); }

void SessionRecorder::attach(host::OrientationSource& source) {
    if (sensors_) sensors_->attach(source);
}

void SessionRecorder::sample(const host::OrientationSample& s) {
    // Not under mutex_: a JPEG written under that one would hold up the sensor's reader thread
    // (the sensor recording has a lock of its own).
    if (sensors_) sensors_->sample(s);
}

void SessionRecorder::frame(const capture::CameraFrame& f) {
    const std::lock_guard lock(mutex_);
    if (!frames_csv_ || !error_.empty()) return;
    char name[32];
    std::snprintf(name, sizeof name, "frames/%06llu.jpg", static_cast<unsigned long long>(frames_));
    cv::Mat bgr;
    cv::cvtColor(f.rgb, bgr, cv::COLOR_RGB2BGR);
    if (!cv::imwrite((dir_ / name).string(), bgr, {cv::IMWRITE_JPEG_QUALITY, 90})) {
        error_ = "cannot write " + (dir_ / name).string();
        return;
    }
    capture::FrameRecord r;
    r.index = frames_++;
    r.t_ns = f.t_ns;
    r.exposure_s = f.exposure_s;
    r.analogue_gain = f.analogue_gain;
    r.digital_gain = f.digital_gain;
    r.file = name;
    std::fputs(capture::frames_csv_line(r).c_str(), frames_csv_);
    std::fputc('\n', frames_csv_);
    std::fflush(frames_csv_);
}

void SessionRecorder::event(const capture::SessionEvent& e) {
    const std::lock_guard lock(mutex_);
    if (!events_csv_) return;
    std::fputs(capture::session_events_csv_line(e).c_str(), events_csv_);
    std::fputc('\n', events_csv_);
    std::fflush(events_csv_);
}

std::string SessionRecorder::close() {
    const std::lock_guard lock(mutex_);
    for (std::FILE** f : {&frames_csv_, &events_csv_}) {
        if (!*f) continue;
        if (std::fflush(*f) != 0 || fsync(fileno(*f)) != 0) error_ = "cannot sync " + dir_.string() + ": " + std::strerror(errno);
        std::fclose(*f);
        *f = nullptr;
    }
    if (sensors_ && !sensors_->close() && error_.empty()) error_ = sensors_->error();
    return error_;
}

}  // namespace glint::app
