#include "appliance/app/calibration_wizard.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "appliance/capture/calibration.hpp"
#include "appliance/capture/calibration_io.hpp"
#include "appliance/capture/session.hpp"
#include "appliance/core/atomic_file.hpp"
#include "appliance/core/errors.hpp"
#include "appliance/core/rotation.hpp"

namespace glint::app {
namespace fs = std::filesystem;
using ui::CalibrationKind;

namespace {

constexpr double kPi = 3.14159265358979323846;

const char* slug(CalibrationKind k) {
    switch (k) {
        case CalibrationKind::CameraIntrinsics: return "camera";
        case CalibrationKind::Response: return "response";
        case CalibrationKind::Vignetting: return "vignetting";
        case CalibrationKind::Alignment: return "alignment";
        case CalibrationKind::TimeOffset: return "time-offset";
    }
    return "calibration";
}

bool collects_motion(CalibrationKind k) { return k == CalibrationKind::Alignment || k == CalibrationKind::TimeOffset; }

// The frames a kind keeps before it computes (-1: the motion decides, feed_alignment).
int wanted_frames(CalibrationKind k, const WizardSettings& s) {
    switch (k) {
        case CalibrationKind::CameraIntrinsics: return s.intrinsics_views;
        case CalibrationKind::Response: return s.bracket_frames;
        case CalibrationKind::Vignetting: return s.flat_frames;
        default: return -1;
    }
}

// The board's corners in a frame (empty when fewer than 6 are seen).
std::vector<cv::Point2f> charuco_corners(const cv::Mat& rgb, const cv::Ptr<cv::aruco::CharucoBoard>& board) {
    cv::Mat grey;
    cv::cvtColor(rgb, grey, cv::COLOR_RGB2GRAY);
    std::vector<std::vector<cv::Point2f>> markers;
    std::vector<int> ids;
    cv::aruco::detectMarkers(grey, board->dictionary, markers, ids);
    if (ids.size() < 4) return {};
    std::vector<cv::Point2f> corners;
    std::vector<int> corner_ids;
    if (cv::aruco::interpolateCornersCharuco(markers, ids, grey, board, corners, corner_ids) < 6) return {};
    return corners;
}

// Share of pixels with a channel at 250 or more, and the mean code.
std::pair<double, double> clipping_and_mean(const cv::Mat& rgb) {
    long long clipped = 0;
    double sum = 0;
    for (int v = 0; v < rgb.rows; ++v) {
        const cv::Vec3b* row = rgb.ptr<cv::Vec3b>(v);
        for (int u = 0; u < rgb.cols; ++u) {
            const cv::Vec3b p = row[u];
            if (std::max({p[0], p[1], p[2]}) >= 250) ++clipped;
            sum += (p[0] + p[1] + p[2]) / 3.0;
        }
    }
    const double n = std::max(1.0, double(rgb.total()));
    return {double(clipped) / n, sum / n};
}

void mark_clipped(cv::Mat& small) {
    for (int v = 0; v < small.rows; ++v)
        for (cv::Vec3b& p : cv::Mat_<cv::Vec3b>(small.row(v)))
            if (std::max({p[0], p[1], p[2]}) >= 250) p = cv::Vec3b(255, 0, 0);
}

std::string format(const char* fmt, auto... args) {
    char buf[512];
    std::snprintf(buf, sizeof buf, fmt, args...);
    return buf;
}

// The response run's second step: the sensor's noise model from the same bracket, read through
// the new curve (`next`, which it updates). A bracket that shows no shot noise or does not fit the
// model keeps the model in force, and the text says why; the new curve is kept either way.
std::string noise_step(const capture::Session& bracket, capture::CameraCalibration& next) {
    try {
        const capture::NoiseResult r = capture::calibrate_noise(bracket, next);
        next.noise_full_well_electrons = r.full_well_electrons;
        next.noise_read = r.read_noise;
        return format("noise: full well %.0f electrons, read noise %.5f (fit RMS %.1f %% over %d frame pairs)",
                      r.full_well_electrons, r.read_noise, 100 * r.fit_rms, r.pairs);
    } catch (const InputError& e) {
        return std::string("noise model kept (") + e.what() + ")";
    }
}

}  // namespace

double bracket_consistency(const std::vector<cv::Mat>& frames, const std::vector<double>& exposures,
                           const std::array<double, 256>& inverse) {
    std::vector<std::size_t> order(frames.size());
    for (std::size_t i = 0; i < order.size(); ++i) order[i] = i;
    std::sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) { return exposures[a] < exposures[b]; });
    std::vector<float> rel;
    for (std::size_t k = 1; k < order.size(); ++k) {
        const cv::Mat& a = frames[order[k - 1]];
        const cv::Mat& b = frames[order[k]];
        if (a.size() != b.size()) continue;
        const double ea = exposures[order[k - 1]], eb = exposures[order[k]];
        // Every 4th pixel in each direction: the median needs no more.
        for (int v = 0; v < a.rows; v += 4) {
            const cv::Vec3b* ra = a.ptr<cv::Vec3b>(v);
            const cv::Vec3b* rb = b.ptr<cv::Vec3b>(v);
            for (int u = 0; u < a.cols; u += 4)
                for (int c = 0; c < 3; ++c) {
                    const int za = ra[u][c], zb = rb[u][c];
                    if (za < 16 || za > 239 || zb < 16 || zb > 239) continue;
                    const double la = inverse[std::size_t(za)] / ea, lb = inverse[std::size_t(zb)] / eb;
                    if (la + lb <= 0) continue;
                    rel.push_back(float(std::abs(la - lb) / (0.5 * (la + lb))));
                }
        }
    }
    if (rel.empty()) return -1;
    std::nth_element(rel.begin(), rel.begin() + std::ptrdiff_t(rel.size() / 2), rel.end());
    return rel[rel.size() / 2];
}

CalibrationWizard::CalibrationWizard(WizardSettings settings, const capture::CameraCalibration& current, Log log)
    : settings_(std::move(settings)), log_(std::move(log)), board_(capture::make_charuco_board(settings_.board)),
      current_(current) {
    worker_ = std::thread([this] { worker_loop(); });
}

CalibrationWizard::~CalibrationWizard() {
    {
        const std::lock_guard lock(mutex_);
        stop_ = true;
        ++run_;  // whatever is queued is dropped
    }
    work_cv_.notify_all();
    idle_cv_.notify_all();
    worker_.join();
}

void CalibrationWizard::start(CalibrationKind kind, const std::string& stamp) {
    std::unique_lock lock(mutex_);
    if (running_) {
        ++run_;
        log_(std::string("calibration wizard: ") + slug(kind_) + " cancelled (another started)");
    }
    ++run_;
    queue_.clear();
    kind_ = kind;
    running_ = true;
    computing_ = false;
    kept_ = 0;
    last_kept_ns_ = 0;
    views_.clear();
    exposures_.clear();
    base_exposure_ = 0;
    bracket_index_ = 0;
    frames_since_request_ = 0;
    hint_.clear();
    orientations_.clear();
    for (double& t : turned_deg_) t = 0;
    result_text_.clear();
    result_.reset();
    frames_csv_ = capture::frames_csv_header() + "\n";
    session_ = settings_.sessions_dir / (std::string(slug(kind)) + "-" + stamp);
    try {
        // Older runs go first: the state partition holds a few.
        std::error_code ec;
        std::vector<fs::path> old;
        if (fs::is_directory(settings_.sessions_dir, ec))
            for (const fs::directory_entry& e : fs::directory_iterator(settings_.sessions_dir, ec))
                if (e.is_directory()) old.push_back(e.path());
        std::sort(old.begin(), old.end(), [](const fs::path& a, const fs::path& b) {
            std::error_code e1, e2;
            return fs::last_write_time(a, e1) < fs::last_write_time(b, e2);
        });
        for (std::size_t i = 0; i + std::size_t(std::max(0, settings_.keep_sessions - 1)) < old.size(); ++i)
            fs::remove_all(old[i], ec);
        fs::remove_all(session_, ec);
        fs::create_directories(session_ / "frames");
        write_text_atomically(session_ / "session.json", capture::session_json("glint run: calibration wizard") + "\n");
        capture::save_calibration(session_ / "calibration.json", current_);
    } catch (const std::exception& e) {
        running_ = false;
        result_text_ = std::string("cannot write the wizard's frames: ") + e.what();
        log_("calibration wizard: " + result_text_);
        return;
    }
    log_(std::string("calibration wizard: ") + slug(kind) + " started; frames go to " + session_.string());
}

void CalibrationWizard::cancel() {
    const std::lock_guard lock(mutex_);
    if (!running_) return;
    ++run_;
    queue_.clear();
    running_ = computing_ = false;
    result_text_ = "cancelled";
    log_(std::string("calibration wizard: ") + slug(kind_) + " cancelled");
    idle_cv_.notify_all();
}

void CalibrationWizard::feed(const ui::KioskPoll& input) {
    std::unique_lock lock(mutex_);
    // A replay's clock waits for the calibration too: what follows a run is then the same on any machine.
    if (settings_.never_drop) idle_cv_.wait(lock, [&] { return !computing_ || stop_; });
    if (!running_ || computing_) return;
    if (collects_motion(kind_)) {
        feed_alignment(input.orientations);
        if (!running_ || computing_) return;
    }
    for (const capture::CameraFrame& f : input.frames) {
        if (kind_ == CalibrationKind::Response) {
            if (base_exposure_ <= 0) base_exposure_ = f.exposure_s * f.total_gain();
            // A camera that cannot give an exposure (beyond its range) is not waited for long.
            if (!settings_.never_drop && ++frames_since_request_ > 15) {
                ++bracket_index_;
                frames_since_request_ = 0;
            }
        }
        if (collects_motion(kind_)) {
            // 10 frames a second are plenty for the pairs' turns, and bound the work.
            if (last_kept_ns_ != 0 && f.t_ns - last_kept_ns_ < 100'000'000) continue;
            if (orientations_.empty()) {
                hint_ = "no orientation from the sensor";
                continue;
            }
            last_kept_ns_ = f.t_ns;  // claimed here: the worker only writes it
        }
        if (settings_.never_drop) {
            idle_cv_.wait(lock, [&] { return queue_.size() < 2 || stop_; });
        } else if (!queue_.empty() && !collects_motion(kind_)) {
            queue_.pop_front();  // a newer frame replaces the one not looked at yet
        } else if (queue_.size() >= 8) {
            continue;
        }
        queue_.push_back({f, run_});
        work_cv_.notify_one();
    }
}

void CalibrationWizard::feed_alignment(const std::vector<capture::SensorOrientation>& orientations) {
    const bool pan_only = kind_ == CalibrationKind::TimeOffset;
    const double target = pan_only ? settings_.time_offset_turn_deg : settings_.axis_turn_deg;
    const glm::dquat x = current_.sensor_from_camera;
    for (const capture::SensorOrientation& s : orientations) {
        orientations_.push_back(s);
        // The turn since the last anchor, in the camera's axes (x right, y up, z out of the lens
        // backwards). Only turns of 2 degrees count, each to the axis that dominates it, so that
        // the sensor's jitter and a hand's wobble add nothing.
        if (orientations_.size() == 1) anchor_ = 0;
        const glm::dquat rel =
            unit_rotation(glm::conjugate(x) * glm::conjugate(orientations_[anchor_].world_from_sensor) * s.world_from_sensor * x);
        const glm::dvec3 v = rotation_vector(rel) * (180 / kPi);
        const double angle = glm::length(v);
        if (angle < 2) continue;
        for (int i = 0; i < 3; ++i)
            if (std::abs(v[i]) >= 0.6 * angle) turned_deg_[i] += std::abs(v[i]);
        anchor_ = orientations_.size() - 1;
    }
    const bool done = pan_only ? turned_deg_[1] >= target
                               : turned_deg_[0] >= target && turned_deg_[1] >= target && turned_deg_[2] >= target;
    if (done || kept_ >= 400) {
        computing_ = true;
        queue_.push_back({capture::CameraFrame{}, run_});  // an empty frame: compute once the frames are written
        work_cv_.notify_one();
    }
}

double CalibrationWizard::asked_exposure_locked() const {
    const int half = (settings_.bracket_frames - 1) / 2;
    return base_exposure_ * std::ldexp(1.0, bracket_index_ - half);
}

std::optional<capture::ExposureRequest> CalibrationWizard::exposure_request() const {
    const std::lock_guard lock(mutex_);
    if (!running_ || computing_ || kind_ != CalibrationKind::Response || base_exposure_ <= 0) return std::nullopt;
    capture::ExposureRequest r;
    r.automatic = false;
    r.exposure_s = std::max(current_.min_exposure_s, asked_exposure_locked());
    r.analogue_gain = 1;
    return r;
}

std::string CalibrationWizard::step_text_locked() const {
    if (computing_) return "Computing the calibration from " + std::to_string(kept_) + " frames ...";
    std::string text;
    switch (kind_) {
        case CalibrationKind::CameraIntrinsics:
            text = format("Hold the calibration board in view and move it: each view in a new place, size or tilt, "
                          "the whole picture covered (%d of %d views)",
                          kept_, settings_.intrinsics_views);
            break;
        case CalibrationKind::Response:
            text = format("Point the camera at a still view with bright and dark parts and hold it still while the "
                          "exposure steps (%d of %d exposures)",
                          kept_, settings_.bracket_frames);
            break;
        case CalibrationKind::Vignetting:
            text = format("Fill the view with an evenly lit white surface (or put the diffuser over the lens) and hold "
                          "still (%d of %d frames)",
                          kept_, settings_.flat_frames);
            break;
        case CalibrationKind::Alignment: {
            const double t = settings_.axis_turn_deg;
            const char* what = turned_deg_[1] < t   ? "Turn the camera slowly left and right (pan)"
                               : turned_deg_[0] < t ? "Tilt the camera slowly up and down"
                                                    : "Roll the camera slowly about its lens";
            text = format("%s. Pan %.0f, tilt %.0f, roll %.0f of %.0f degrees", what, std::min(t, turned_deg_[1]),
                          std::min(t, turned_deg_[0]), std::min(t, turned_deg_[2]), t);
            break;
        }
        case CalibrationKind::TimeOffset:
            text = format("Turn the camera left and right, quickly and back (%.0f of %.0f degrees)",
                          std::min(settings_.time_offset_turn_deg, turned_deg_[1]), settings_.time_offset_turn_deg);
            break;
    }
    if (!hint_.empty()) text += " - " + hint_;
    return text;
}

WizardView CalibrationWizard::view() const {
    const std::lock_guard lock(mutex_);
    WizardView v;
    v.running = running_;
    v.computing = computing_;
    v.kind = kind_;
    v.result = result_text_;
    v.can_apply = result_.has_value() && !running_;
    if (!running_) return v;
    v.step = step_text_locked();
    switch (kind_) {
        case CalibrationKind::CameraIntrinsics:
        case CalibrationKind::Response:
        case CalibrationKind::Vignetting: v.progress = double(kept_) / wanted_frames(kind_, settings_); break;
        case CalibrationKind::Alignment:
            v.progress = (std::min(settings_.axis_turn_deg, turned_deg_[0]) + std::min(settings_.axis_turn_deg, turned_deg_[1]) +
                          std::min(settings_.axis_turn_deg, turned_deg_[2])) /
                         (3 * settings_.axis_turn_deg);
            break;
        case CalibrationKind::TimeOffset:
            v.progress = std::min(1.0, turned_deg_[1] / settings_.time_offset_turn_deg);
            break;
    }
    if (computing_) v.progress = 1;
    return v;
}

bool CalibrationWizard::preview_since(WizardPreview& out) const {
    const std::lock_guard lock(mutex_);
    if (preview_.version == out.version || preview_.rgba.empty()) return false;
    out = preview_;
    return true;
}

std::optional<capture::CameraCalibration> CalibrationWizard::result() const {
    const std::lock_guard lock(mutex_);
    if (running_) return std::nullopt;
    return result_;
}

void CalibrationWizard::set_current(const capture::CameraCalibration& calibration) {
    const std::lock_guard lock(mutex_);
    current_ = calibration;
    result_.reset();
}

void CalibrationWizard::wait_idle() {
    std::unique_lock lock(mutex_);
    idle_cv_.wait(lock, [&] { return (queue_.empty() && !busy_) || stop_; });
}

void CalibrationWizard::worker_loop() {
    std::unique_lock lock(mutex_);
    for (;;) {
        work_cv_.wait(lock, [&] { return stop_ || !queue_.empty(); });
        if (stop_) return;
        Job job = std::move(queue_.front());
        queue_.pop_front();
        if (job.run != run_) continue;
        busy_ = true;
        idle_cv_.notify_all();  // a slot in the queue
        lock.unlock();
        try {
            if (job.frame.rgb.empty()) compute(job.run);
            else look_at(job);
        } catch (const std::exception& e) {
            const std::lock_guard relock(mutex_);
            if (job.run == run_) finish_locked(std::string("failed: ") + e.what(), false);
        }
        lock.lock();
        busy_ = false;
        idle_cv_.notify_all();
    }
}

void CalibrationWizard::set_preview(const cv::Mat& rgb, const std::function<void(cv::Mat&, double)>& draw) {
    const double scale = std::min(1.0, double(settings_.preview_width) / std::max(1, rgb.cols));
    cv::Mat small;
    if (scale < 1) cv::resize(rgb, small, cv::Size(), scale, scale, cv::INTER_AREA);
    else small = rgb.clone();
    if (draw) draw(small, scale);
    cv::Mat rgba;
    cv::cvtColor(small, rgba, cv::COLOR_RGB2RGBA);
    const std::lock_guard lock(mutex_);
    preview_.width = rgba.cols;
    preview_.height = rgba.rows;
    preview_.rgba.assign(rgba.data, rgba.data + rgba.total() * 4);
    ++preview_.version;
}

void CalibrationWizard::look_at(Job& job) {
    const cv::Mat& rgb = job.frame.rgb;
    CalibrationKind kind;
    {
        const std::lock_guard lock(mutex_);
        if (job.run != run_) return;
        kind = kind_;
    }
    // The heavy part of each kind first, without the lock.
    std::vector<cv::Point2f> corners;
    double clipped = 0, mean = 0;
    switch (kind) {
        case CalibrationKind::CameraIntrinsics:
            corners = charuco_corners(rgb, board_);
            set_preview(rgb, [&](cv::Mat& small, double scale) {
                for (const cv::Point2f& c : corners)
                    cv::circle(small, c * scale, 3, cv::Scalar(0, 255, 0), cv::FILLED, cv::LINE_AA);
            });
            break;
        case CalibrationKind::Response:
        case CalibrationKind::Vignetting:
            std::tie(clipped, mean) = clipping_and_mean(rgb);
            set_preview(rgb, [](cv::Mat& small, double) { mark_clipped(small); });
            break;
        case CalibrationKind::Alignment:
        case CalibrationKind::TimeOffset: set_preview(rgb, {}); break;
    }
    fs::path file;
    {
        const std::lock_guard lock(mutex_);
        if (job.run != run_ || computing_) return;
        const bool decided = decide_locked(job.frame, corners, clipped, mean);
        if (!decided) return;
        file = reserve_frame_locked(job.frame);
    }
    // The frame is written outside the lock (the frame thread must not wait for a PNG).
    cv::Mat bgr;
    cv::cvtColor(rgb, bgr, cv::COLOR_RGB2BGR);
    if (!cv::imwrite(file.string(), bgr, {cv::IMWRITE_PNG_COMPRESSION, 1}))
        throw RuntimeError(file.string() + ": cannot write the frame");
    const std::lock_guard lock(mutex_);
    if (job.run != run_ || kind_ != kind) return;
    const int wanted = wanted_frames(kind, settings_);
    const bool bracket_over = kind == CalibrationKind::Response && bracket_index_ >= settings_.bracket_frames;
    if (!computing_ && ((wanted > 0 && kept_ >= wanted) || bracket_over)) {
        computing_ = true;
        queue_.push_back({capture::CameraFrame{}, run_});
        work_cv_.notify_one();
    }
}

bool CalibrationWizard::decide_locked(const capture::CameraFrame& frame, const std::vector<cv::Point2f>& corners,
                                      double clipped, double mean) {
    hint_.clear();
    switch (kind_) {
        case CalibrationKind::CameraIntrinsics: {
            if (corners.size() < 8) {
                hint_ = "the board is not seen (whole board in view, no glare)";
                return false;
            }
            // Where the view is (centroid) and how large (mean distance of the corners from it),
            // in units of the image diagonal; a tilt changes both.
            const double diag = std::hypot(frame.rgb.cols, frame.rgb.rows);
            cv::Point2d c(0, 0);
            for (const cv::Point2f& p : corners) c += cv::Point2d(p);
            c *= 1.0 / double(corners.size());
            double spread = 0;
            for (const cv::Point2f& p : corners) spread += cv::norm(cv::Point2d(p) - c);
            spread /= double(corners.size()) * diag;
            const cv::Point3d view(c.x / diag, c.y / diag, spread);
            if (kept_ > 0 && frame.t_ns - last_kept_ns_ < 400'000'000) return false;  // the same gesture
            const bool seen = std::any_of(views_.begin(), views_.end(), [&](const cv::Point3d& k) {
                return std::hypot(k.x - view.x, k.y - view.y) < 0.08 && std::abs(view.z / k.z - 1) < 0.25;
            });
            if (seen) {
                hint_ = "move the board to a new place, distance or tilt";
                return false;
            }
            views_.push_back(view);
            return true;
        }
        case CalibrationKind::Response: {
            const double e = frame.exposure_s * frame.total_gain();
            const bool distinct = std::none_of(exposures_.begin(), exposures_.end(),
                                               [&](double k) { return std::max(k, e) / std::min(k, e) < 1.25; });
            if (!distinct || mean <= 0) return false;
            exposures_.push_back(e);
            // The exposure asked for came: ask for the next.
            if (std::abs(e / asked_exposure_locked() - 1) < 0.05) {
                ++bracket_index_;
                frames_since_request_ = 0;
            }
            return true;
        }
        case CalibrationKind::Vignetting:
            if (clipped > 0.01) hint_ = "too bright: part of the view is clipped";
            else if (mean < 40) hint_ = "too dark: light the surface more";
            else return !(kept_ > 0 && frame.t_ns - last_kept_ns_ < 200'000'000);
            return false;
        case CalibrationKind::Alignment:
        case CalibrationKind::TimeOffset: return true;
    }
    return false;
}

fs::path CalibrationWizard::reserve_frame_locked(const capture::CameraFrame& frame) {
    char name[32];
    std::snprintf(name, sizeof name, "frames/%06d.png", kept_);
    capture::FrameRecord r;
    r.index = std::uint64_t(kept_);
    r.t_ns = frame.t_ns;
    r.exposure_s = frame.exposure_s;
    r.analogue_gain = frame.analogue_gain;
    r.digital_gain = frame.digital_gain;
    r.file = name;
    frames_csv_ += capture::frames_csv_line(r) + "\n";
    last_kept_ns_ = frame.t_ns;
    ++kept_;
    return session_ / name;
}

void CalibrationWizard::compute(std::uint64_t run) {
    CalibrationKind kind;
    fs::path dir;
    capture::CameraCalibration current;
    std::vector<capture::SensorOrientation> orientations;
    {
        const std::lock_guard lock(mutex_);
        if (run != run_) return;
        kind = kind_;
        dir = session_;
        current = current_;
        orientations = orientations_;
        write_text_atomically(dir / "frames.csv", frames_csv_);
    }
    const capture::Session s = capture::open_session(dir);
    capture::CameraCalibration next = current;
    std::string text;
    switch (kind) {
        case CalibrationKind::CameraIntrinsics: {
            const capture::IntrinsicsResult r = capture::calibrate_intrinsics(s, settings_.board);
            next.intrinsics = r.intrinsics;
            const capture::Intrinsics& k = r.intrinsics;
            text = format("RMS reprojection error %.2f px over %d views (%d corners); fx %.1f fy %.1f cx %.1f cy %.1f "
                          "k1 %.3f k2 %.3f",
                          r.rms_px, r.views, r.corners, k.fx, k.fy, k.cx, k.cy, k.k1, k.k2);
            break;
        }
        case CalibrationKind::Response: {
            const capture::ResponseResult r = capture::calibrate_response(s);
            next.response = r.response;
            std::vector<cv::Mat> frames;
            std::vector<double> exposures;
            for (const capture::FrameRecord& f : s.frames) {
                frames.push_back(capture::load_frame(s, f).rgb);
                exposures.push_back(f.exposure_s * f.analogue_gain * f.digital_gain);
            }
            const double now = bracket_consistency(frames, exposures, r.response.inverse);
            const double before = bracket_consistency(frames, exposures, current.response.inverse);
            text = format("%d exposures over %.0fx; neighbouring exposures agree within %.1f %% (median; %.1f %% with "
                          "the curve in force); ",
                          r.frames, r.exposure_span, 100 * now, 100 * before) +
                   capture::response_coverage(r);
            text += "; " + noise_step(s, next);
            break;
        }
        case CalibrationKind::Vignetting: {
            const capture::VignettingResult r = capture::calibrate_vignetting(s, current);
            next.vignetting = r.vignetting;
            const capture::Intrinsics& k = current.intrinsics;
            const double corner = r.vignetting.at(k, 0, 0);
            text = format("fit RMS %.4f over %lld pixels of %d frames; the corner gets %.0f %% of the centre's light "
                          "(a1 %.4f a2 %.4f a3 %.4f)",
                          r.fit_rms, r.pixels, r.frames, 100 * corner, r.vignetting.a1, r.vignetting.a2, r.vignetting.a3);
            break;
        }
        case CalibrationKind::Alignment:
        case CalibrationKind::TimeOffset: {
            // The three-axis motion shows the rolling shutter's readout too (its pitch and roll
            // sweeps): measured with the mounting, or kept, with the reason, where the motion does
            // not show it. The turns about the vertical alone (time offset) do not.
            std::string readout_text;
            const capture::AlignmentAndReadout both =
                kind == CalibrationKind::Alignment ? capture::calibrate_alignment_and_readout(s, orientations)
                                                   : capture::AlignmentAndReadout{capture::calibrate_alignment(s, orientations), std::nullopt, {}};
            if (kind == CalibrationKind::Alignment) {
                if (both.readout) {
                    next.readout_s = both.readout->readout_s;
                    readout_text = format("; readout %.1f ms (standard deviation %.1f ms; was %.1f ms)",
                                          both.readout->readout_s * 1e3, both.readout->sd_s * 1e3,
                                          current.readout_s * 1e3);
                } else {
                    readout_text = "; readout kept at " + format("%.1f ms", current.readout_s * 1e3) + " (" +
                                   both.readout_refused + ")";
                }
            }
            const capture::AlignmentResult& r = both.alignment;
            // The time offset alone needs no turn about every axis; the mounting does.
            if (kind == CalibrationKind::Alignment) capture::check_alignment_usable(r, "alignment");
            next.time_offset_s = r.time_offset_s;
            if (kind == CalibrationKind::Alignment) next.sensor_from_camera = r.sensor_from_camera;
            const double moved = angle_between(r.sensor_from_camera, current.sensor_from_camera) * 180 / kPi;
            text = kind == CalibrationKind::Alignment
                       ? format("median residual %.2f degrees over %d frame pairs; time offset %.1f ms; the mounting "
                                "moved %.2f degrees from the calibration in force",
                                r.residual_deg, r.pairs, r.time_offset_s * 1e3, moved) +
                             readout_text
                       : format("time offset %.1f ms (was %.1f ms); median residual %.2f degrees over %d frame pairs",
                                r.time_offset_s * 1e3, current.time_offset_s * 1e3, r.residual_deg, r.pairs);
            break;
        }
    }
    const std::lock_guard lock(mutex_);
    if (run != run_) return;
    result_ = next;
    finish_locked(text, true);
}

void CalibrationWizard::finish_locked(std::string result, bool ok) {
    running_ = computing_ = false;
    queue_.clear();
    if (!ok) result_.reset();
    result_text_ = std::move(result);
    log_(std::string("calibration wizard: ") + slug(kind_) + ": " + result_text_);
}

}  // namespace glint::app
