// `glint calibrate response|vignetting|noise|alignment|intrinsics --session DIR --calibration FILE`:
// one camera calibration from recorded frames, written into the calibration file (created from
// the session's calibration.json when absent). On a simulated session, the result is also
// compared with the session's truth (appliance/capture; docs/capture.md).
#include <cstdio>
#include <memory>

#include "appliance/app/commands.hpp"
#include "appliance/capture/calibration.hpp"
#include "appliance/capture/calibration_io.hpp"
#include "appliance/capture/calibration_truth.hpp"
#include "appliance/capture/charuco.hpp"

namespace glint::app {
namespace {

struct CalibrateArgs {
    std::string session, calibration;
};

// Each step reads the session, updates its part of `cal` and prints one line (and, on a
// simulated session, one line against the truth).
using CalibrationStep = void (*)(const capture::Session& s, capture::CameraCalibration& cal, const std::string& file);

void calibrate_response(const capture::Session& s, capture::CameraCalibration& cal, const std::string& file) {
    const capture::ResponseResult r = capture::calibrate_response(s);
    cal.response = r.response;
    std::printf("response from %d frames spanning %.0fx in exposure, %s -> %s\n", r.frames, r.exposure_span,
                capture::response_coverage(r).c_str(), file.c_str());
    if (s.has_truth)
        std::printf("against the session's truth: worst relative error %.2f %% over codes 64..250\n",
                    100 * capture::response_error_against_truth(r.response, capture::truth_calibration(s).response));
}

void calibrate_vignetting(const capture::Session& s, capture::CameraCalibration& cal, const std::string& file) {
    const capture::VignettingResult r = capture::calibrate_vignetting(s, cal);
    cal.vignetting = r.vignetting;
    std::printf("vignetting from %d frames, %lld pixels: a1 %.5f a2 %.5f a3 %.5f, fit RMS %.5f -> %s\n", r.frames,
                r.pixels, r.vignetting.a1, r.vignetting.a2, r.vignetting.a3, r.fit_rms, file.c_str());
}

void calibrate_noise(const capture::Session& s, capture::CameraCalibration& cal, const std::string& file) {
    const capture::NoiseResult r = capture::calibrate_noise(s, cal);
    cal.noise_full_well_electrons = r.full_well_electrons;
    cal.noise_read = r.read_noise;
    std::printf("noise from %d frame pairs, %lld pixel channels in %d exposure bins: full well %.0f electrons, read "
                "noise %.5f (relative exposure), fit RMS %.1f %% -> %s\n",
                r.pairs, r.samples, r.bins, r.full_well_electrons, r.read_noise, 100 * r.fit_rms, file.c_str());
    if (s.has_truth && capture::truth_calibration(s).noise_full_well_electrons > 0) {
        const capture::NoiseError e =
            capture::noise_error_against_truth(r.full_well_electrons, r.read_noise, cal.response, capture::truth_calibration(s));
        std::printf("against the session's truth: full well %+.1f %%, read noise %+.1f %%\n", 100 * e.full_well,
                    100 * e.read_noise);
    }
}

void calibrate_alignment(const capture::Session& s, capture::CameraCalibration& cal, const std::string& file) {
    const capture::AlignmentResult r = capture::calibrate_alignment(s);
    // Before anything is written: a mounting the motion could not pin down keeps the one in force.
    capture::check_alignment_usable(r, s.dir.string());
    cal.sensor_from_camera = r.sensor_from_camera;
    cal.time_offset_s = r.time_offset_s;
    std::printf("alignment from %d frame pairs: time offset %.4f s, median residual %.3f degrees -> %s\n", r.pairs,
                r.time_offset_s, r.residual_deg, file.c_str());
    std::printf("the motion pins the mounting down to %.3f degrees (noise alone, one standard deviation) about its "
                "least-turned axis (camera %+.2f %+.2f %+.2f)\n",
                r.mounting_sd_deg, r.weakest_axis.x, r.weakest_axis.y, r.weakest_axis.z);
    if (s.has_truth) {
        const capture::CameraCalibration truth = capture::truth_calibration(s);
        std::printf("mounting against the session's truth: %.3f degrees\n",
                    capture::mounting_error_deg(r.sensor_from_camera, truth.sensor_from_camera));
        std::printf("time offset against the session's truth: %.2f ms\n", (r.time_offset_s - truth.time_offset_s) * 1e3);
    }
}

void calibrate_readout(const capture::Session& s, capture::CameraCalibration& cal, const std::string& file) {
    const capture::ReadoutResult r = capture::calibrate_readout(s);
    cal.readout_s = r.readout_s;
    std::printf("readout from %d frame pairs: %.2f ms (standard deviation %.2f ms; was %.2f ms) -> %s\n", r.pairs,
                r.readout_s * 1e3, r.sd_s * 1e3, s.calibration.readout_s * 1e3, file.c_str());
    std::printf("at that readout: time offset %.4f s, median residual %.3f degrees (the mounting is not written: "
                "glint calibrate alignment)\n",
                r.alignment.time_offset_s, r.alignment.residual_deg);
    if (s.has_truth)
        std::printf("readout against the session's truth: %.2f ms\n",
                    (r.readout_s - capture::truth_calibration(s).readout_s) * 1e3);
}

void calibrate_intrinsics(const capture::Session& s, capture::CameraCalibration& cal, const std::string& file) {
    const capture::IntrinsicsResult r = capture::calibrate_intrinsics(s, {});
    cal.intrinsics = r.intrinsics;
    const capture::Intrinsics& k = r.intrinsics;
    std::printf("intrinsics from %d views (%d corners): fx %.2f fy %.2f cx %.2f cy %.2f k1 %.4f k2 %.4f p1 %.5f "
                "p2 %.5f k3 %.4f, RMS reprojection %.3f px -> %s\n",
                r.views, r.corners, k.fx, k.fy, k.cx, k.cy, k.k1, k.k2, k.p1, k.p2, k.k3, r.rms_px, file.c_str());
}

struct StepSpec {
    const char* name;
    const char* description;
    const char* session_help;
    CalibrationStep run;
};

constexpr StepSpec kSteps[] = {
    {"response", "Inverse response curve from an exposure bracket of a still view (OpenCV CalibrateRobertson)",
     "Session holding the bracket (e.g. glint simulate --bracket 12)", calibrate_response},
    {"vignetting",
     "Vignetting from flat-field frames (a uniformly lit view filling the frame), using the calibration's response",
     "Session holding the flat-field frames", calibrate_vignetting},
    {"noise",
     "The sensor's noise model (full well, read noise) from an exposure bracket of a still view, using the "
     "calibration's response: consecutive frames compared pixel by pixel",
     "Session holding the bracket (e.g. glint simulate --bracket 12; calibrate its response first)", calibrate_noise},
    {"alignment",
     "Camera-to-sensor rotation and time offset from rotation-only motion (best: glint simulate --trajectory "
     "alignment, turns about all three axes): image rotations between consecutive frames against the sensor's",
     "Session of the calibration motion (or a scan over rows at several pitches) with its sensor recording; a "
     "motion that leaves the mounting loose about some axis is refused and nothing is written",
     calibrate_alignment},
    {"readout",
     "The rolling shutter's readout time (top row to bottom row) from a motion with its sensor recording: the "
     "alignment solved at readouts from 0 ms (up to 200 ms), the one whose frame pairs fit the sensor's turns best",
     "Session of the calibration motion (glint simulate --trajectory alignment: its pitch and roll sweeps show the "
     "readout) with its sensor recording; a motion that does not show it is refused and nothing is written",
     calibrate_readout},
    {"intrinsics",
     "Focal lengths, principal point and distortion from views of a ChArUco board (7x5 squares of 4 cm, 3 cm "
     "markers, DICT_5X5_100), with the RMS reprojection error",
     "Session of board views (e.g. glint simulate --charuco 16)", calibrate_intrinsics},
};

}  // namespace

Command add_calibrate_command(CLI::App& app) {
    auto a = std::make_shared<CalibrateArgs>();
    CLI::App* cmd = app.add_subcommand("calibrate", std::string(command_summary("calibrate").summary));
    cmd->require_subcommand(1);
    std::vector<std::pair<CLI::App*, CalibrationStep>> steps;
    for (const StepSpec& spec : kSteps) {
        CLI::App* step = cmd->add_subcommand(spec.name, spec.description);
        step->add_option("--session", a->session, spec.session_help)->required();
        step->add_option("--calibration", a->calibration,
                         "Calibration file to update (created from the session's calibration.json when absent)")
            ->required();
        steps.emplace_back(step, spec.run);
    }
    return {cmd, [a, steps] {
                const capture::Session s = capture::open_session(a->session);
                capture::CameraCalibration cal = capture::calibration_to_update(a->calibration, s);
                for (const auto& [step, run] : steps)
                    if (step->parsed()) run(s, cal, a->calibration);
                capture::check_calibration_usable(cal, a->calibration);
                capture::save_calibration(a->calibration, cal);
                return 0;
            }};
}

}  // namespace glint::app
