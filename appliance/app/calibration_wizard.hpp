// The maintenance menu's calibration wizards (docs/kiosk.md, "Calibration wizards"): the same
// calibrations as `glint calibrate` (capture/calibration.hpp, capture/charuco.hpp), run on the
// kiosk's live input step by step. The wizard tells the technician what to do, keeps the frames
// that serve (each run is written as a session directory, so that it can be exported and run
// again with `glint calibrate`), drives the camera's exposure where the calibration needs it,
// shows a preview of what it sees, and when it has enough, computes the calibration on its own
// thread and states the error. Apply hands back the new calibration; saving it is the caller's.
//
//   camera (intrinsics)  views of the ChArUco board, each new in position, size or tilt; the
//                        result's error is the RMS reprojection error of the board's corners
//   response             an exposure bracket of a still view (the wizard sets the exposures; a
//                        replay takes the recorded ones); the error is how far the bracket's
//                        frames, linearised with the new curve and divided by their exposures,
//                        disagree (median over the pixels seen well in two neighbouring frames);
//                        then the sensor's noise model (full well, read noise) from the same
//                        bracket through the new curve, kept as it was when the bracket shows no
//                        shot noise or does not fit the model (the result says which)
//   vignetting           flat-field frames (an evenly lit white surface filling the view, or a
//                        diffuser over the lens); the error is the fit's RMS
//   alignment            the three-axis motion: turns about the camera's vertical axis, its
//                        horizontal axis and its lens axis, each until the bar is full; the
//                        error is the median angle between image and sensor rotations; the
//                        rolling shutter's readout is measured from the same motion (kept, with
//                        the reason, when the motion does not show it)
//   time offset          turns about the vertical axis only; keeps the mounting, sets the offset
//
// Threads: feed(), exposure_request() and view() are called on the frame thread and are cheap;
// the detection, the writing of frames and the calibration run on the wizard's worker thread.
#pragma once

#include <array>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <filesystem>
#include <functional>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "appliance/capture/camera_model.hpp"
#include "appliance/capture/camera_source.hpp"
#include "appliance/capture/charuco.hpp"
#include "appliance/ui/kiosk_source.hpp"
#include "appliance/ui/maintenance_menu.hpp"

namespace glint::app {

struct WizardSettings {
    std::filesystem::path sessions_dir;  // each run's frames: DIR/<kind>-<stamp>/ (a session)
    int keep_sessions = 8;               // older runs are removed (the state partition is small)
    capture::CharucoSpec board;          // the printed calibration board
    int intrinsics_views = 12;
    int bracket_frames = 11;             // exposures 2^-5 .. 2^5 around the camera's own
    int flat_frames = 8;
    double axis_turn_deg = 60;           // alignment: turning about each axis adds up to this
    double time_offset_turn_deg = 90;    // time offset: about the vertical axis
    int preview_width = 480;             // the preview image's width (its height follows the frame)
    // A replay's frames are all looked at, and its frames wait while the calibration is computed
    // (the frame thread waits for the worker), so that the result and what follows it do not
    // depend on the machine's speed; live frames are skipped while the worker is busy.
    bool never_drop = false;
};

// What the menu's calibration page shows.
struct WizardView {
    bool running = false;      // collecting or computing
    bool computing = false;
    ui::CalibrationKind kind = ui::CalibrationKind::CameraIntrinsics;
    std::string step;          // what to do now, with the count
    double progress = 0;       // 0..1 of what the step collects
    std::string result;        // the last run's result (or why it failed)
    bool can_apply = false;    // a result that Apply would keep
};

// The preview: the latest frame looked at, downscaled, as RGBA, with what the wizard found drawn
// on it (the board's corners, clipped pixels in red).
struct WizardPreview {
    int width = 0, height = 0;
    std::vector<std::uint8_t> rgba;
    std::uint64_t version = 0;  // grows with every new preview
};

class CalibrationWizard {
public:
    using Log = std::function<void(const std::string&)>;
    CalibrationWizard(WizardSettings settings, const capture::CameraCalibration& current, Log log);
    ~CalibrationWizard();
    CalibrationWizard(const CalibrationWizard&) = delete;
    CalibrationWizard& operator=(const CalibrationWizard&) = delete;

    // Starts a run (a running one is cancelled first). `stamp` names its session directory.
    void start(ui::CalibrationKind kind, const std::string& stamp);
    void cancel();
    // The frame thread's input of this frame (frames and orientations in time order).
    void feed(const ui::KioskPoll& input);
    // What the camera's exposure must be now (nullopt: the camera's own automatic exposure).
    std::optional<capture::ExposureRequest> exposure_request() const;
    WizardView view() const;
    // Copies the preview into `out` when it is newer than out.version; false when it is not.
    bool preview_since(WizardPreview& out) const;
    // The calibration Apply keeps: the current one with the run's result put in (nullopt: none).
    std::optional<capture::CameraCalibration> result() const;
    // After Apply: the calibration in force (the next runs start from it).
    void set_current(const capture::CameraCalibration& calibration);
    // Waits until the worker has nothing left to do (tests, replays at their end).
    void wait_idle();

private:
    struct Job {
        capture::CameraFrame frame;
        std::uint64_t run = 0;
    };
    void worker_loop();
    void look_at(Job& job);                 // worker: one frame
    // Worker, locked: whether the frame serves (and the hint when not), from what look_at found.
    bool decide_locked(const capture::CameraFrame& frame, const std::vector<cv::Point2f>& corners, double clipped,
                       double mean);
    // Worker, locked: the kept frame's number, frames.csv line and file to write.
    std::filesystem::path reserve_frame_locked(const capture::CameraFrame& frame);
    void compute(std::uint64_t run);        // worker: the calibration from the kept frames
    void set_preview(const cv::Mat& rgb, const std::function<void(cv::Mat&, double scale)>& draw);
    void feed_alignment(const std::vector<capture::SensorOrientation>& orientations);  // frame thread, locked
    std::string step_text_locked() const;
    // Response: the exposure x gain the ladder asks for now (2^(index - half) of the camera's own).
    double asked_exposure_locked() const;
    void finish_locked(std::string result, bool ok);

    WizardSettings settings_;
    Log log_;
    cv::Ptr<cv::aruco::CharucoBoard> board_;
    mutable std::mutex mutex_;
    std::condition_variable work_cv_, idle_cv_;
    std::deque<Job> queue_;
    bool busy_ = false, stop_ = false;
    std::thread worker_;

    // The run (under mutex_).
    capture::CameraCalibration current_;
    ui::CalibrationKind kind_ = ui::CalibrationKind::CameraIntrinsics;
    std::uint64_t run_ = 0;          // grows with every start and cancel: stale jobs are dropped
    bool running_ = false, computing_ = false;
    std::filesystem::path session_;  // this run's directory
    std::string frames_csv_;
    int kept_ = 0;                   // frames kept
    std::int64_t last_kept_ns_ = 0;
    std::vector<cv::Point3d> views_; // intrinsics: each kept view's corner centroid (x, y) and spread
    std::vector<double> exposures_;  // response: each kept frame's exposure x gain
    double base_exposure_ = 0;       // response: the camera's own exposure when the run started
    int bracket_index_ = 0;          // response: the exposure asked for now
    int frames_since_request_ = 0;
    std::string hint_;               // why the last frame was not kept ("" = none)
    std::vector<capture::SensorOrientation> orientations_;  // alignment, time offset
    std::size_t anchor_ = 0;         // the orientation the turns are measured from
    double turned_deg_[3] = {0, 0, 0};  // about the camera's x (tilt), y (pan) and z (roll) axes
    std::string result_text_;
    std::optional<capture::CameraCalibration> result_;
    WizardPreview preview_;
};

// The bracket's consistency (the response wizard's error): frames in `exposures` order, their
// codes linearised with `inverse_response` (256 entries) and divided by exposure; for each pair of
// neighbouring frames, the relative difference at pixels with codes 16..239 in both; the median.
double bracket_consistency(const std::vector<cv::Mat>& frames, const std::vector<double>& exposures,
                           const std::array<double, 256>& inverse_response);

}  // namespace glint::app
