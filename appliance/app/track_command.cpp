// `glint track --frames DIR (--calibration FILE | --intrinsics fx,fy,cx,cy[,k1,k2,p1,p2,k3])
//  --out poses.csv [--sequence] [--sensors replay:FILE] [--fps F] [--board FILE]` and
// `glint track --print-board OUT.png [--px-per-mm K] [--board FILE]`: the board's pose in every
// PNG of a directory (appliance/tracking; docs/tracking.md "The command").
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <memory>
#include <opencv2/imgcodecs.hpp>
#include <sstream>

#include "appliance/app/cli_util.hpp"
#include "appliance/app/commands.hpp"
#include "appliance/capture/calibration_io.hpp"
#include "appliance/core/atomic_file.hpp"
#include "appliance/core/errors.hpp"
#include "appliance/core/strict_number.hpp"
#include "appliance/tracking/board_print.hpp"
#include "appliance/tracking/tracker.hpp"
#include "appliance/ui/ar_camera.hpp"
#include "firmware_bridge/host/replay_source.hpp"
#include "firmware_bridge/host/source_spec.hpp"

namespace glint::app {
namespace {

namespace fs = std::filesystem;

struct TrackArgs {
    std::string frames, calibration, intrinsics, out, sensors, board, print_board;
    double px_per_mm = 4, fps = 30;
    bool sequence = false;
};

struct CameraSetup {
    tracking::Camera camera;
    glm::dquat sensor_from_camera{1, 0, 0, 0};  // OpenCV camera frame -> sensor
    double time_offset_s = 0;                   // camera time + offset = sensor time
};

// --intrinsics fx,fy,cx,cy[,k1,k2,p1,p2,k3]; the size comes from the frames.
tracking::Camera parse_intrinsics(const std::string& text) {
    const std::vector<std::string> items = split_list(text, "--intrinsics");
    if (items.size() != 4 && items.size() != 9)
        throw InputError("--intrinsics: want fx,fy,cx,cy or fx,fy,cx,cy,k1,k2,p1,p2,k3 (got " +
                         std::to_string(items.size()) + " values)");
    std::vector<double> v;
    for (const std::string& item : items) v.push_back(parse_double(item, "--intrinsics"));
    if (!(v[0] > 0) || !(v[1] > 0)) throw InputError("--intrinsics: fx and fy must be > 0");
    tracking::Camera c;
    c.fx = v[0], c.fy = v[1], c.cx = v[2], c.cy = v[3];
    if (v.size() == 9) c.k1 = v[4], c.k2 = v[5], c.p1 = v[6], c.p2 = v[7], c.k3 = v[8];
    return c;
}

// The capture module's calibration file: intrinsics, and the camera-sensor alignment, whose
// camera frame is the OpenGL-style one (-Z forward, +Y up): OpenCV's is that turned by pi
// about X.
CameraSetup setup_from_calibration(const std::string& path) {
    const capture::CameraCalibration cal = capture::load_calibration(path);
    CameraSetup s;
    const capture::Intrinsics& k = cal.intrinsics;
    s.camera = ui::tracking_camera(k);
    s.sensor_from_camera = unit_rotation(cal.sensor_from_camera * ui::kGlFromCv);
    s.time_offset_s = cal.time_offset_s;
    return s;
}

std::vector<fs::path> list_pngs(const std::string& dir) {
    std::error_code ec;
    if (!fs::is_directory(dir, ec)) throw InputError("--frames: " + dir + " is not a directory");
    std::vector<fs::path> files;
    for (const fs::directory_entry& e : fs::directory_iterator(dir, ec)) {
        std::string ext = e.path().extension().string();
        std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char ch) { return char(std::tolower(ch)); });
        if (e.is_regular_file() && ext == ".png") files.push_back(e.path());
    }
    if (ec) throw InputError("--frames: " + dir + ": " + ec.message());
    if (files.empty()) throw InputError("--frames: no PNG files in " + dir);
    std::sort(files.begin(), files.end(), [](const fs::path& a, const fs::path& b) {
        return a.filename().string() < b.filename().string();
    });
    return files;
}

// Frame times of a recorded session's frames (DIR/../frames.csv: index,t_ns,...,file), by file
// name; empty when there is none.
std::map<std::string, double> session_frame_times(const std::string& dir) {
    std::map<std::string, double> times;
    const fs::path csv = fs::path(dir).lexically_normal().parent_path() / "frames.csv";
    std::ifstream in(csv);
    if (!in) return times;
    std::string line;
    std::getline(in, line);
    int number = 1;
    while (std::getline(in, line)) {
        ++number;
        if (line.empty()) continue;
        std::vector<std::string> fields;
        std::stringstream ss(line);
        for (std::string f; std::getline(ss, f, ',');) fields.push_back(f);
        if (fields.size() < 6) throw InputError(csv.string() + ":" + std::to_string(number) + ": want 6 fields");
        const double t = double(parse_int(fields[1], csv.string() + ":" + std::to_string(number))) * 1e-9;
        times[fs::path(fields[5]).filename().string()] = t;
    }
    return times;
}

std::vector<tracking::OrientationSample> read_sensor_replay(const std::string& spec_text, double time_offset_s) {
    host::SourceSpec spec;
    try {
        spec = host::parse_source_spec(spec_text);
    } catch (const host::SourceError& e) {
        throw InputError(std::string("--sensors: ") + e.what());
    }
    if (spec.kind != host::SourceKind::Replay) throw InputError("--sensors: only replay:FILE is read offline");
    std::unique_ptr<host::ReplaySource> source;
    try {
        source = std::make_unique<host::ReplaySource>("sensors", spec.path, host::ReplayPacing::Fast);
    } catch (const host::SourceError& e) {
        throw InputError(std::string("--sensors: ") + e.what());
    }
    std::vector<tracking::OrientationSample> samples;
    // Sensor time - offset = camera time of the same instant.
    source->set_sample_callback([&](const host::OrientationSample& s) {
        samples.push_back({double(s.t_ns) * 1e-9 - time_offset_s, s.world_from_sensor});
    });
    source->run_to_end();
    if (samples.empty()) throw InputError("--sensors: " + spec.path + " holds no orientation samples");
    return samples;
}

std::string csv_number(double v) {
    char buffer[32];
    std::snprintf(buffer, sizeof buffer, "%.12g", v);
    return buffer;
}

int run_track(const TrackArgs& a) {
    const tracking::Board board(a.board.empty() ? tracking::BoardSpec{} : tracking::load_board_spec(a.board));
    if (!a.print_board.empty()) {
        const cv::Mat image = tracking::draw_board(board, a.px_per_mm);
        write_file_atomically(a.print_board, [&](const fs::path& temp) {
            if (!cv::imwrite(temp.string() + ".png", image)) throw RuntimeError(a.print_board + ": cannot be written");
            fs::rename(temp.string() + ".png", temp);
        });
        std::printf("board %dx%d markers of %.0f mm (%s), %.0fx%.0f mm, %dx%d px at %.3g px/mm -> %s\n",
                    board.spec().columns, board.spec().rows, board.spec().marker_mm, board.spec().dictionary.c_str(),
                    board.width_m() * 1000, board.height_m() * 1000, image.cols, image.rows, a.px_per_mm,
                    a.print_board.c_str());
        return 0;
    }
    if (a.frames.empty() || a.out.empty())
        throw InputError("--frames and --out are required (or --print-board OUT.png)");
    if (a.calibration.empty() == a.intrinsics.empty())
        throw InputError("give one of --calibration FILE and --intrinsics fx,fy,cx,cy[,...]");
    if (!a.sensors.empty() && !a.sequence) throw InputError("--sensors needs --sequence (frames are independent otherwise)");
    CameraSetup setup;
    if (!a.calibration.empty()) setup = setup_from_calibration(a.calibration);
    else setup.camera = parse_intrinsics(a.intrinsics);
    const std::vector<fs::path> files = list_pngs(a.frames);
    const std::map<std::string, double> times = session_frame_times(a.frames);
    std::vector<tracking::OrientationSample> samples;
    if (!a.sensors.empty()) samples = read_sensor_replay(a.sensors, setup.time_offset_s);
    const double t0 = samples.empty() ? 0.0 : samples.front().t;

    std::unique_ptr<tracking::Tracker> tracker;   // --sequence
    std::unique_ptr<tracking::Detector> detector;  // independent frames
    std::size_t next_sample = 0;
    std::string csv = "file,detected,qw,qx,qy,qz,tx,ty,tz,quality\n";
    int detected = 0, bridged = 0;
    for (std::size_t i = 0; i < files.size(); ++i) {
        const cv::Mat gray = cv::imread(files[i].string(), cv::IMREAD_GRAYSCALE);
        if (gray.empty()) throw InputError(files[i].string() + ": not a readable PNG");
        if (!tracker && !detector) {
            if (setup.camera.width == 0) setup.camera.width = gray.cols, setup.camera.height = gray.rows;
            if (a.sequence) tracker = std::make_unique<tracking::Tracker>(board, setup.camera, setup.sensor_from_camera);
            else detector = std::make_unique<tracking::Detector>(board, setup.camera);
        }
        if (gray.cols != setup.camera.width || gray.rows != setup.camera.height)
            throw InputError(files[i].string() + ": " + std::to_string(gray.cols) + "x" + std::to_string(gray.rows) +
                             " frame, the calibration is for " + std::to_string(setup.camera.width) + "x" +
                             std::to_string(setup.camera.height));
        const auto time = times.find(files[i].filename().string());
        const double t = time != times.end() ? time->second : t0 + double(i) / a.fps;
        tracking::TrackResult r;
        if (tracker) {
            // The sensor's samples up to a little past the frame (for the slerp at its time).
            while (next_sample < samples.size() && samples[next_sample].t <= t + 0.1)
                tracker->add_orientation(samples[next_sample++]);
            r = tracker->track(t, gray);
        } else {
            r.detection = detector->detect(gray);
            r.detected = r.has_pose = r.detection.detected;
            r.pose = r.detection.pose;
        }
        detected += r.detected;
        bridged += !r.detected && r.has_pose;
        csv += files[i].filename().string() + "," + (r.detected ? "1" : "0");
        if (r.has_pose) {
            const glm::dquat q = unit_rotation(r.pose.rotation);
            for (double v : {q.w, q.x, q.y, q.z, r.pose.translation.x, r.pose.translation.y, r.pose.translation.z})
                csv += "," + csv_number(v);
        } else {
            csv += ",,,,,,,";
        }
        csv += "," + (r.detected ? csv_number(r.detection.rms_px) : std::string()) + "\n";
    }
    write_text_atomically(a.out, csv);
    std::printf("%zu frames: board detected in %d", files.size(), detected);
    if (a.sequence) std::printf(", bridged in %d", bridged);
    std::printf(" -> %s\n", a.out.c_str());
    return 0;
}

}  // namespace

Command add_track_command(CLI::App& app) {
    auto a = std::make_shared<TrackArgs>();
    CLI::App* cmd = app.add_subcommand("track", std::string(command_summary("track").summary));
    cmd->add_option("--frames", a->frames, "Directory of PNG frames, read in name order");
    cmd->add_option("--calibration", a->calibration,
                    "Camera calibration file (glint calibrate): intrinsics, distortion, camera-sensor alignment");
    cmd->add_option("--intrinsics", a->intrinsics, "fx,fy,cx,cy[,k1,k2,p1,p2,k3] in pixels (instead of --calibration)");
    cmd->add_option("--out", a->out, "CSV: file,detected,qw,qx,qy,qz,tx,ty,tz,quality (camera_from_board, OpenCV "
                                     "camera frame, metres; quality = reprojection RMS px)");
    cmd->add_flag("--sequence", a->sequence,
                  "The frames are a sequence: filter the pose and bridge dropouts (with --sensors) for 0.5 s, "
                  "then fade over 0.25 s");
    cmd->add_option("--sensors", a->sensors, "Orientation source for the dropout bridge: replay:FILE (a recording)");
    cmd->add_option("--fps", a->fps,
                    "Frame rate of a sequence without the session's frames.csv beside DIR (frame i at i/fps after "
                    "the first sensor sample)")
        ->check(CLI::Range(1.0, 1000.0));
    cmd->add_option("--board", a->board, "Board file (JSON: columns, rows, marker_mm, gap_mm, margin_mm, dictionary, "
                                         "first_id); default 5x7 DICT_4X4_50 markers of 40 mm, 10 mm gaps");
    cmd->add_option("--print-board", a->print_board, "Write the board as a printable PNG and exit");
    cmd->add_option("--px-per-mm", a->px_per_mm, "Resolution of --print-board, pixels per millimetre")
        ->check(CLI::Range(0.1, 100.0));
    return {cmd, [a] { return run_track(*a); }};
}

}  // namespace glint::app
