// Capture accuracy and speed (docs/capture.md, "Benchmark"): for courtyard, studio and sunset, a guided scan
// simulated with a heading drift of 1 deg/min, noise and auto-exposure; the captured map against
// the true one (log luminance), the irradiance and n = 160 maps made from each, the calibrations,
// the per-frame times, and the guided logic's completion. Writes tests/bench/results/capture.md.
#include <chrono>
#include <cmath>
#include <cstdio>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "appliance/capture/calibration.hpp"
#include "appliance/capture/calibration_io.hpp"
#include "appliance/capture/capture_pipeline.hpp"
#include "appliance/capture/charuco.hpp"
#include "appliance/capture/replay_camera.hpp"
#include "appliance/capture/session.hpp"
#include "appliance/convolution/convolution.hpp"
#include "appliance/core/equirect.hpp"
#include "appliance/core/error_metrics.hpp"
#include "appliance/core/exr_io.hpp"
#include "appliance/gl/gl_context.hpp"
#include "appliance/sim/session_simulator.hpp"
#include "tests/bench/bench_util.hpp"

namespace fs = std::filesystem;
using namespace glint;
using namespace glint::capture;

namespace {

using sim::simulate_charuco_session;
using sim::simulate_session;
using sim::SimulateOptions;
using sim::SimulateSummary;

const std::string kWorlds = "/usr/share/blender/datafiles/studiolights/world";

// Weighted RMS of ln(captured / true) luminance over covered texels (solid-angle weights).
double log_luminance_rms(const HdrImage& got, const HdrImage& truth_full, const HdrImage& coverage) {
    const HdrImage truth = resample_bilinear(truth_full, got.width(), got.height());
    const std::vector<double> om = row_solid_angles(got.width(), got.height());
    double num = 0, den = 0;
    for (int j = 0; j < got.height(); ++j)
        for (int i = 0; i < got.width(); ++i) {
            if (coverage.at(i, j).b < 0.5f) continue;
            const Rgb a = got.at(i, j), b = truth.at(i, j);
            const double la = (a.r + a.g + a.b) / 3.0, lb = (b.r + b.g + b.b) / 3.0;
            if (!(la > 0) || !(lb > 0)) continue;
            const double d = std::log(la / lb);
            num += om[std::size_t(j)] * d * d;
            den += om[std::size_t(j)];
        }
    return den > 0 ? std::sqrt(num / den) : 0;
}

struct Row {
    std::string map;
    CaptureSummary on, off, gpu, refined;
    double log_rms_on = 0, log_rms_off = 0, irr_on = 0, irr_off = 0, n160_on = 0, n160_off = 0;
    double log_rms_ref = 0, irr_ref = 0, n160_ref = 0;
    int frames = 0;
    double duration = 0;
};

}  // namespace

int main(int argc, char** argv) {
    std::string out = "tests/bench/results/capture.md";
    for (int i = 1; i < argc; ++i)
        if (std::string(argv[i]) == "--out" && i + 1 < argc) out = argv[++i];
    const fs::path work = fs::temp_directory_path() / "glint-bench-capture";
    fs::remove_all(work);
    fs::create_directories(work);
    std::vector<Row> rows;
    const gl::EglDisplay display = gl::EglDisplay::surfaceless();
    const gl::GlContext gpu(display);
    for (const char* name : {"courtyard", "studio", "sunset"}) {
        std::fprintf(stderr, "bench: %s\n", name);
        SimulateOptions so;
        so.env = kWorlds + "/" + name + ".exr";
        so.out = work / name;
        so.fps = 3;
        so.guided_speed_deg_s = 35;  // 63 s: past the 60 s the drift target speaks of
        so.heading_drift_deg_per_min = 1.0;
        so.hdr_bracket = true;  // frames with a clipped pixel get shorter exposures
        so.threads = 2;
        const SimulateSummary sim = simulate_session(so);
        Row r;
        r.map = name;
        r.frames = sim.frames;
        r.duration = sim.duration_s;
        CaptureOptions co;
        co.session = so.out;
        co.threads = 2;
        host::VirtualClock clock;
        ReplayCamera camera(open_session(so.out), clock);
        co.out = work / (std::string(name) + "-on.exr");
        r.on = run_capture(co, camera);
        co.out = work / (std::string(name) + "-ref.exr");
        co.global_adjustment = false;
        r.refined = run_capture(co, camera);
        co.global_adjustment = true;
        co.out = work / (std::string(name) + "-off.exr");
        co.drift_correction = false;
        r.off = run_capture(co, camera);
        co.out = work / (std::string(name) + "-gpu.exr");
        r.gpu = run_capture(co, camera, &gpu);
        const HdrImage truth = load_exr(so.env).image;
        const std::vector<HdrImage> want = bench::downstream_maps(truth);
        struct Variant {
            const char* suffix;
            double *log_rms, *irr, *n160;
        };
        for (const Variant& v : {Variant{"-on.exr", &r.log_rms_on, &r.irr_on, &r.n160_on},
                                 Variant{"-off.exr", &r.log_rms_off, &r.irr_off, &r.n160_off},
                                 Variant{"-ref.exr", &r.log_rms_ref, &r.irr_ref, &r.n160_ref}}) {
            const fs::path map = work / (std::string(name) + v.suffix);
            const HdrImage got = load_exr(map).image;
            const HdrImage cov = load_exr(coverage_path_for(map)).image;
            const std::vector<HdrImage> have = bench::downstream_maps(got);
            *v.log_rms = log_luminance_rms(got, truth, cov);
            *v.irr = compare_maps(have[0], want[0]).weighted_relative_rms;
            *v.n160 = compare_maps(have[1], want[1]).weighted_relative_rms;
        }
        rows.push_back(r);
    }

    // Calibrations against the simulator's truth.
    std::fprintf(stderr, "bench: calibrations\n");
    SimulateOptions b;
    b.env = kWorlds + "/courtyard.exr";
    b.out = work / "bracket";
    b.bracket = 18;
    b.bracket_first_exposure_s = 3e-6;
    simulate_session(b);
    const Session bs = open_session(b.out);
    const ResponseResult resp = calibrate_response(bs);
    const CameraCalibration truth_cal = load_calibration(b.out / "truth" / "calibration.json");
    double resp_worst = 0;
    for (int z = 100; z <= 250; ++z)
        resp_worst = std::max(resp_worst, std::abs((resp.response.inverse[std::size_t(z)] / resp.response.inverse[128]) /
                                                       (truth_cal.response.inverse[std::size_t(z)] / truth_cal.response.inverse[128]) -
                                                   1));
    HdrImage flat(64, 32);
    for (int j = 0; j < 32; ++j)
        for (int i = 0; i < 64; ++i) flat.set(i, j, {0.5f, 0.5f, 0.5f});
    save_exr(work / "flat.exr", flat);
    std::ofstream(work / "still.csv") << "0,1,0,0,0\n4,1,0,0,0\n";
    SimulateOptions f;
    f.env = work / "flat.exr";
    f.out = work / "flat";
    f.trajectory = (work / "still.csv").string();
    f.fps = 2;
    simulate_session(f);
    const VignettingResult vig = calibrate_vignetting(open_session(f.out), truth_cal);
    double vig_worst = 0;
    for (double rr = 0; rr <= 1.0; rr += 0.05) {
        const double r2 = rr * rr;
        const auto v = [&](const Vignetting& g) { return 1 + r2 * (g.a1 + r2 * (g.a2 + r2 * g.a3)); };
        vig_worst = std::max(vig_worst, std::abs(v(vig.vignetting) - v(truth_cal.vignetting)));
    }
    SimulateOptions c;
    c.out = work / "charuco";
    c.width = 640;
    c.height = 360;
    simulate_charuco_session(c, 24);
    const IntrinsicsResult intr = calibrate_intrinsics(open_session(c.out), {});
    const Intrinsics ti = load_calibration(c.out / "truth" / "calibration.json").intrinsics;
    const AlignmentResult al = calibrate_alignment(open_session(work / "courtyard"));
    const double align_err = angle_between(al.sensor_from_camera, truth_cal.sensor_from_camera) * 180 / kPi;

    std::time_t now = std::time(nullptr);
    char date[64];
    std::strftime(date, sizeof date, "%Y-%m-%d %H:%M UTC", std::gmtime(&now));
    std::ofstream md(out);
    md << "# Capture: accuracy and speed\n\nGenerated by `tests/bench/run_capture_bench.sh` on " << date << ", "
       << bench::machine_description() << ", 2 threads.\n\n"
       << "Sessions: `glint simulate` of each map, the guided scan at 35 deg/s (about 63 s), 320x180 frames over "
          "70 degrees at 3 fps, raw IMU with Mahony fusion on the board plus a heading drift of 1 deg/min, camera "
          "noise, the simulator's response and vignetting, auto-exposure, and after any frame with a clipped pixel extra frames at 1/64, 1/4096, ... of its exposure until none clips, at most four (`--hdr-bracket`; no shortest exposure: the sensor limits are off, docs/capture.md). Capture into 1024x512 from the "
          "recorded sensor stream (CPU engine unless noted), with the saturation-aware sampling and the exposure bands of docs/capture.md. The downstream maps are irradiance (128x64) and "
          "n = 160 (256x128) by `auto`, from the captured map against the same from the true map.\n\n"
       << "| map | frames | exposure swing | orientation error median / max / max after 60 s | log-luminance RMS (covered) | irradiance | n = 160 | guided complete after |\n"
       << "|---|---|---|---|---|---|---|---|\n";
    for (const Row& r : rows) {
        const auto orient = [](const CaptureSummary& s) {
            return bench::fmt("%.3f", s.orientation_error_median_deg.value_or(-1)) + " / " +
                   bench::fmt("%.3f", s.orientation_error_max_deg.value_or(-1)) + " / " +
                   bench::fmt("%.3f", s.orientation_error_after_60s_max_deg.value_or(-1)) + " deg";
        };
        md << "| " << r.map << ", drift correction and global adjustment (default) | " << r.frames << " | " << bench::fmt("%.1f", r.on.exposure_stops)
           << " stops | " << orient(r.on) << " | " << bench::fmt("%.3f", r.log_rms_on) << " | "
           << bench::fmt("%.2f", 100 * r.irr_on) << " % | " << bench::fmt("%.2f", 100 * r.n160_on) << " % | "
           << (r.on.guided_complete_after_s ? bench::fmt("%.1f s", *r.on.guided_complete_after_s) : std::string("never"))
           << " |\n";
        md << "| " << r.map << ", live pass only (`--no-global-adjustment`) | | | " << orient(r.refined) << " | "
           << bench::fmt("%.3f", r.log_rms_ref) << " | " << bench::fmt("%.2f", 100 * r.irr_ref) << " % | "
           << bench::fmt("%.2f", 100 * r.n160_ref) << " % | |\n";
        md << "| " << r.map << ", off | | | " << orient(r.off) << " | " << bench::fmt("%.3f", r.log_rms_off) << " | "
           << bench::fmt("%.2f", 100 * r.irr_off) << " % | " << bench::fmt("%.2f", 100 * r.n160_off) << " % | |\n";
    }
    md << "\nTargets: irradiance within 5 %, n = 160 within 10 %, orientation error under 0.5 deg after 60 s of "
          "1 deg/min drift.\n\n## Time per frame (2 threads; GPU = Mesa llvmpipe on the same cores)\n\n"
       << "| map | CPU accumulation | GPU accumulation (incl. glFinish) | drift correction (live) | global adjustment in the "
          "frame loop: mean / most | kept map in the frame loop: mean / most | last frame to finished map (to saved) |\n"
          "|---|---|---|---|---|---|---|\n";
    for (const Row& r : rows) {
        const double frames = std::max(1, r.on.frames_used);
        md << "| " << r.map << " | " << bench::fmt("%.1f", 1e3 * r.on.accumulate_seconds / r.on.frames_used) << " ms | "
           << bench::fmt("%.1f", 1e3 * r.gpu.accumulate_seconds / r.gpu.frames_used) << " ms | "
           << bench::fmt("%.1f", 1e3 * r.on.drift_seconds / std::max(1, r.on.drift_considered)) << " ms | "
           << bench::fmt("%.1f", 1e3 * r.on.online_seconds / frames) << " / "
           << bench::fmt("%.0f", 1e3 * r.on.online_max_frame_seconds) << " ms (" << r.on.adjust_pairs << " of "
           << r.on.adjust_pairs_tried << " pairs; drift found " << bench::fmt("%.2f", r.on.adjust_drift_deg_per_min)
           << " deg/min) | " << bench::fmt("%.1f", 1e3 * r.on.map_seconds / frames) << " / "
           << bench::fmt("%.0f", 1e3 * r.on.map_max_frame_seconds) << " ms (" << r.on.map_rebuilds << " rebuilds) | "
           << bench::fmt("%.2f", r.on.last_frame_to_map_seconds) << " s ("
           << bench::fmt("%.2f", r.on.last_frame_to_saved_seconds) << " s) |\n";
    }
    md << "\n## Calibrations against the simulator's truth\n\n| calibration | result |\n|---|---|\n"
       << "| response (18-frame bracket, noise) | worst " << bench::fmt("%.1f", 100 * resp_worst)
       << " % over codes 100..250 (ratios to code 128) |\n"
       << "| vignetting (9 flat-field frames) | V(r) within " << bench::fmt("%.4f", vig_worst) << " |\n"
       << "| intrinsics (24 ChArUco views, 640x360) | RMS reprojection " << bench::fmt("%.3f", intr.rms_px) << " px; fx "
       << bench::fmt("%.2f", intr.intrinsics.fx) << " (true " << bench::fmt("%.2f", ti.fx) << "), cx "
       << bench::fmt("%.2f", intr.intrinsics.cx) << " (" << bench::fmt("%.2f", ti.cx) << "), cy "
       << bench::fmt("%.2f", intr.intrinsics.cy) << " (" << bench::fmt("%.2f", ti.cy) << ") |\n"
       << "| alignment (courtyard scan) | mounting off by " << bench::fmt("%.2f", align_err) << " deg, time offset "
       << bench::fmt("%.1f", al.time_offset_s * 1e3) << " ms (true 0), " << al.pairs << " pairs |\n";
    std::printf("bench: wrote %s\n", out.c_str());
    fs::remove_all(work);
    return 0;
}
