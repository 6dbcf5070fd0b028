#include "appliance/capture/capture_pipeline.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <cstdio>
#include <chrono>
#include <cstdlib>
#include <map>

#include "appliance/capture/drift_correction.hpp"
#include "appliance/capture/gpu_accumulator.hpp"
#include "appliance/capture/guided_capture.hpp"
#include "appliance/capture/hdr_accumulator.hpp"
#include "appliance/capture/global_adjustment.hpp"
#include "appliance/capture/session.hpp"
#include "appliance/core/atomic_file.hpp"
#include "appliance/core/equirect.hpp"
#include "appliance/core/errors.hpp"
#include "appliance/core/exr_io.hpp"
#include "appliance/core/parallel.hpp"
#include "firmware_bridge/host/replay_source.hpp"

namespace glint::capture {

namespace fs = std::filesystem;

fs::path coverage_path_for(const fs::path& env_out) {
    fs::path p = env_out;
    p.replace_filename(env_out.stem().string() + ".coverage.exr");
    return p;
}

// A rolling-shutter frame as a global shutter at the frame's time would have seen it: each pixel
// read where its ray (pixel_rays, seen with the frame's orientation) fell in the row exposed when
// the camera had turned on by w (rad/s, camera frame) x that row's time (rolling_shutter_project),
// bilinearly in code values. A channel beside a clipped code (255) stays clipped, so that every
// reader still finds its value unreliable; a pixel no row saw is marked clipped too. Black would
// not do: the planes average X over a cell and read it bilinearly, so black pixels darken the
// cells beside them and make an edge that moves with the lean (on studio at 160x90 the global
// adjustment's pair error went from 0.12 to 0.38 degrees RMS with them).
// What the drift correction and the pair alignment are given: they turn every pixel of a frame
// with its one orientation. The accumulators turn each texel's row instead (exact, no resampling).
CameraFrame deskew_rolling_shutter(const CameraFrame& f, const CameraCalibration& cal, const std::vector<glm::dvec3>& pixel_rays,
                     const glm::dvec3& w, int threads) {
    const Intrinsics& k = cal.intrinsics;
    CameraFrame out = f;
    out.rgb = cv::Mat(f.rgb.rows, f.rgb.cols, CV_8UC3);
    parallel_for(k.height, threads, [&](int v) {
        std::uint8_t* o = out.rgb.ptr<std::uint8_t>(v);
        for (int u = 0; u < k.width; ++u) {
            const std::size_t i = std::size_t(v) * std::size_t(k.width) + std::size_t(u);
            const std::optional<PixelCoord> px = rolling_shutter_project(cal, pixel_rays[i], w);
            if (!px) {
                o[3 * u] = o[3 * u + 1] = o[3 * u + 2] = 255;
                continue;
            }
            const int u0 = std::clamp(int(std::floor(px->u)), 0, k.width - 2);
            const int v0 = std::clamp(int(std::floor(px->v)), 0, k.height - 2);
            const double fu = std::clamp(px->u - u0, 0.0, 1.0), fv = std::clamp(px->v - v0, 0.0, 1.0);
            const std::uint8_t* a = f.rgb.ptr<std::uint8_t>(v0) + 3 * u0;
            const std::uint8_t* b = f.rgb.ptr<std::uint8_t>(v0 + 1) + 3 * u0;
            for (int c = 0; c < 3; ++c) {
                if (a[c] == 255 || a[3 + c] == 255 || b[c] == 255 || b[3 + c] == 255) {
                    o[3 * u + c] = 255;
                    continue;
                }
                const double z = (1 - fv) * ((1 - fu) * a[c] + fu * a[3 + c]) + fv * ((1 - fu) * b[c] + fu * b[3 + c]);
                o[3 * u + c] = std::uint8_t(std::clamp(std::lround(z), 0L, 254L));
            }
        }
    });
    return out;
}


namespace {

// world_from_camera per frame index from the session's truth.
std::map<std::uint64_t, glm::dquat> truth_orientations(const Session& s) {
    if (!s.has_truth)
        throw InputError(s.dir.string() + ": --orientations truth needs a simulated session (truth/camera.csv)");
    std::map<std::uint64_t, glm::dquat> out;
    for (const TruthPose& p : load_truth_poses(s)) out[p.index] = p.world_from_camera;
    return out;
}

// world_from_sensor over the whole session, from its recorded sensor stream replayed as the live
// driver published it (host::ReplaySource).
struct SensorTrack {
    std::unique_ptr<host::OrientationHistory> history;
    std::int64_t last_ns = 0;  // the last sample's time (appliance clock)
};

// Every orientation sample of the session's sensor recording, in order.
std::vector<host::OrientationSample> replay_sensor_samples(const Session& s) {
    if (s.sensors.empty()) throw InputError(s.dir.string() + ": the session has no sensor recording (sensors.glrec)");
    host::ReplaySource replay("replay:" + s.sensors.string(), s.sensors.string());
    std::vector<host::OrientationSample> samples;
    replay.set_sample_callback([&](const host::OrientationSample& x) { samples.push_back(x); });
    replay.run_to_end();
    if (samples.size() < 2) throw InputError(s.sensors.string() + ": fewer than two orientation samples");
    return samples;
}

SensorTrack replay_sensors(const Session& s) {
    const std::vector<host::OrientationSample> samples = replay_sensor_samples(s);
    SensorTrack t;
    // Keep everything; a gap over 100 ms (a lost stretch) is not interpolated across.
    t.history = std::make_unique<host::OrientationHistory>(samples.size() + 1, 100'000'000, 0);
    for (const host::OrientationSample& x : samples) t.history->push(x);
    t.last_ns = samples.back().t_ns;
    return t;
}

// Every frame of `camera` from start() until it is finished, in order, with its place in the
// stream. A frame the source could not deliver (a damaged file) is an input error: an offline
// capture is made of all of them.
void for_each_frame(CameraSource& camera, const std::function<void(std::size_t, const CameraFrame&)>& use) {
    camera.start();
    std::size_t n = 0;
    while (!camera.finished()) {
        const std::uint64_t dropped = camera.health().dropped;
        const std::optional<CameraFrame> f = camera.next_frame(std::chrono::seconds(1));
        if (f)
            use(n++, *f);
        else if (camera.health().dropped != dropped)
            throw InputError(camera.health().last_error);
    }
    camera.stop();
}

GroundTruthError compare_with_truth(const HdrImage& got, const std::vector<std::uint32_t>& samples, int min_samples,
                                    const HdrImage& truth_full) {
    const HdrImage truth = resample_bilinear(truth_full, got.width(), got.height());
    const std::vector<double> omega = row_solid_angles(got.width(), got.height());
    double num = 0, den = 0, covered = 0;
    std::vector<double> rel;
    for (int j = 0; j < got.height(); ++j)
        for (int i = 0; i < got.width(); ++i) {
            if (samples[std::size_t(j) * std::size_t(got.width()) + std::size_t(i)] < std::uint32_t(min_samples)) continue;
            const Rgb a = got.at(i, j), b = truth.at(i, j);
            const double o = omega[std::size_t(j)];
            covered += o;
            const double ref[3] = {b.r, b.g, b.b}, val[3] = {a.r, a.g, a.b};
            for (int c = 0; c < 3; ++c) {
                const double d = val[c] - ref[c];
                num += o * d * d;
                den += o * ref[c] * ref[c];
                if (ref[c] > 0) rel.push_back(std::abs(d) / ref[c]);
            }
        }
    GroundTruthError e;
    e.weighted_relative_rms = den > 0 ? std::sqrt(num / den) : 0;
    if (!rel.empty()) {
        std::nth_element(rel.begin(), rel.begin() + std::ptrdiff_t(rel.size() / 2), rel.end());
        e.median_relative = rel[rel.size() / 2];
    }
    e.covered_fraction_compared = covered / (4 * kPi);
    return e;
}

}  // namespace

std::vector<SensorOrientation> load_sensor_orientations(const Session& session) {
    std::vector<SensorOrientation> out;
    for (const host::OrientationSample& x : replay_sensor_samples(session)) out.push_back({x.t_ns, x.world_from_sensor});
    return out;
}

CaptureSummary run_capture(const CaptureOptions& o, CameraSource& camera, const gl::GlContext* gpu,
                           const std::function<void(long long, long long)>& progress) {
    // A map of 2048x1024 takes 0.7 GB while it is made, growing with its texels: 8192x4096 about
    // 11 GB, the old limit of 16384x8192 about 37 GB (a sweep of bad inputs, 2026-12-06).
    if (o.width < 8 || o.height < 4 || o.width > 8192 || o.height > 4096)
        throw InputError("--size must be between 8x4 and 8192x4096");
    if (o.min_samples < 1) throw InputError("--min-samples must be at least 1");
    if (o.adjustment_rounds < 1 || o.adjustment_rounds > 20) throw InputError("--adjustment-rounds must be 1 to 20");
    if (!(o.drift_gain > 0 && o.drift_gain <= 1)) throw InputError("--drift-gain must be in (0, 1]");
    if (o.bracket_fill && gpu)
        throw InputError("--bracket-fill: the GPU accumulator does not fill clipped reads; use --engine cpu");
    const bool live_stream = o.live_calibration.has_value();
    if (live_stream && !o.live_orientation) throw InputError("capture: a live capture needs the orientation sensor");
    if (live_stream && o.orientations == OrientationInput::Truth) throw InputError("capture: a live capture has no truth");
    Session session;
    if (live_stream) session.calibration = *o.live_calibration;
    else session = open_session(o.session);
    const int threads = o.threads > 0 ? o.threads : hardware_threads();
    std::map<std::uint64_t, glm::dquat> truth;
    SensorTrack sensors;
    if (live_stream) {
        // The stream is read as it comes (CaptureOptions::live_orientation).
    } else if (o.orientations == OrientationInput::Truth) {
        truth = truth_orientations(session);
        // The sensor's angular velocity still tells the blur and the rolling shutter, when there is one.
        if (!session.sensors.empty() && (o.max_blur_px > 0 || (o.rolling_shutter && session.calibration.readout_s > 0)))
            sensors = replay_sensors(session);
    } else {
        sensors = replay_sensors(session);
    }
    if (!(o.max_blur_px >= 0)) throw InputError("--max-blur-px must be 0 (no limit) or positive");
    const CameraCalibration& cal = session.calibration;
    // The sensor's orientation at a sensor time: the recording's, or the live stream's.
    const auto sensor_at = [&](std::int64_t t) -> std::optional<glm::dquat> {
        if (live_stream) return o.live_orientation(t);
        if (!sensors.history) return std::nullopt;
        return sensors.history->at(t).world_from_sensor;
    };
    // The camera's orientation at a frame: the sensor's at the frame's time (shifted by the
    // calibrated offset), then the mounting.
    const auto orientation_of = [&](const CameraFrame& f) -> std::optional<glm::dquat> {
        if (o.orientations == OrientationInput::Truth) {
            const auto q = truth.find(f.sequence);
            if (q == truth.end()) return std::nullopt;
            return q->second;
        }
        const std::int64_t t = f.t_ns + std::int64_t(std::llround(cal.time_offset_s * 1e9));
        const std::optional<glm::dquat> s = sensor_at(t);
        if (!s) return std::nullopt;
        return unit_rotation(*s * cal.sensor_from_camera);
    };
    // The camera's angular velocity around a frame's time (camera frame, rad/s): the sensor's turn
    // between 20 ms before and after it (the rows' exposures span about that), carried through the
    // mounting. A drift correction turns the world, not the camera, so it does not change it. 0
    // without a sensor stream or where it has a gap.
    const auto angular_velocity_of = [&](const CameraFrame& f) -> glm::dvec3 {
        if (!live_stream && !sensors.history) return glm::dvec3(0);
        constexpr std::int64_t kHalfSpanNs = 20'000'000;
        const std::int64_t t = f.t_ns + std::int64_t(std::llround(cal.time_offset_s * 1e9));
        const std::optional<glm::dquat> a = sensor_at(t - kHalfSpanNs), b = sensor_at(t + kHalfSpanNs);
        if (!a || !b) return glm::dvec3(0);
        const glm::dvec3 sensor_w = rotation_vector(glm::conjugate(*a) * *b) / (2 * kHalfSpanNs * 1e-9);
        return glm::conjugate(cal.sensor_from_camera) * sensor_w;
    };
    std::map<std::uint64_t, glm::dquat> true_poses;
    if (session.has_truth)
        for (const TruthPose& p : load_truth_poses(session)) true_poses[p.index] = p.world_from_camera;
    // One face for both engines: the CPU reference, or the GPU path on the caller's context (one
    // context for every accumulation of the run).
    struct Engine {
        std::unique_ptr<HdrAccumulator> cpu;
        std::unique_ptr<GpuAccumulator> gpu;
        int threads = 1;
        int frames() const { return cpu ? cpu->frames() : gpu->frames(); }
        void add_frame(const CameraFrame& f, const CameraCalibration& c, const glm::dquat& q, const glm::dvec3& w) {
            if (cpu) cpu->add_frame(f, c, q, threads, w);
            else gpu->add_frame(f, c, q, w);
        }
        HdrImage radiance() const { return cpu ? cpu->radiance(threads) : gpu->radiance(threads); }
        std::vector<std::uint32_t> samples() const { return cpu ? cpu->samples() : gpu->samples(); }
        std::vector<float> weights() const { return cpu ? cpu->weights() : gpu->weights(); }
    };
    const auto make_engine = [&] {
        auto e = std::make_unique<Engine>();
        e->threads = threads;
        if (gpu) e->gpu = std::make_unique<GpuAccumulator>(*gpu, o.width, o.height);
        else {
            AccumulationSettings settings;
            settings.bracket_fill = o.bracket_fill;
            e->cpu = std::make_unique<HdrAccumulator>(o.width, o.height, settings);
        }
        return e;
    };
    std::unique_ptr<Engine> live = make_engine();
    Engine& acc = *live;
    // What the global adjustment needs of each accumulated frame.
    struct UsedFrame {
        std::size_t place;       // in the camera's stream
        std::uint64_t sequence;  // the frame's index in the session
        std::int64_t t_ns;
        glm::dquat sensor, live;
        glm::dvec3 camera_rate;  // the camera's angular velocity (camera frame, rad/s; 0: unknown)
    };
    // What the accumulation turns a frame's rows by, from the camera's rate (0: none, without the
    // rolling shutter).
    const auto rows_turn = [&](const glm::dvec3& camera_rate) { return o.rolling_shutter ? camera_rate : glm::dvec3(0); };
    const auto row_turn = [&](const UsedFrame& u) { return rows_turn(u.camera_rate); };
    std::vector<UsedFrame> used;
    CaptureSummary summary;
    if (!live_stream && o.orientations == OrientationInput::Sensors) {
        // Frames after the recording's last orientation: a recording cut short (a power loss)
        // leaves them without an orientation, which alone would read as frames it could not place.
        // Beyond a second only: a live recording's last sample lags its last frame by the
        // sensor's latency.
        const std::int64_t offset_ns = std::llround(session.calibration.time_offset_s * 1e9);
        constexpr std::int64_t kMarginNs = 1'000'000'000;
        for (const FrameRecord& r : session.frames)
            if (r.t_ns + offset_ns > sensors.last_ns + kMarginNs) ++summary.frames_after_sensor_end;
        if (summary.frames_after_sensor_end > 0)
            summary.sensor_end_before_last_frame_s =
                double(session.frames.back().t_ns + offset_ns - sensors.last_ns) * 1e-9;
    }
    // Progress: the live pass, then (global adjustment) the views, the pairs and the final map.
    const bool adjust = o.drift_correction && o.global_adjustment;
    const bool online = adjust && o.online_adjustment;
    if (live_stream && adjust && !online)
        throw InputError("capture: a live capture adjusts online (the frames cannot be read again after the scan)");
    // A live capture does not know its frames ahead: the total grows with them.
    const long long total = live_stream ? 0
                            : online  ? (long long)session.frames.size() * 2
                            : adjust ? (long long)session.frames.size() * (3 + o.adjustment_rounds)
                                     : (long long)session.frames.size();
    // The global adjustment while the scan runs (global_adjustment.hpp, OnlineAdjustment): each
    // frame's pairs are aligned in the frame loop, and the frames are kept for the final map.
    OnlineAdjustment online_adjustment(threads);
    std::vector<CameraFrame> kept;
    std::vector<glm::dvec3> kept_w;  // their angular velocities for the accumulation
    // The adjusted map, kept during the scan: frames accumulated with the current solution once
    // they are older than the last map_tail_frames, and the whole map accumulated again (a few
    // frames per loop, map_rebuild_per_frame) whenever the solution has moved one of its frames
    // more than map_rebuild_deg. The accumulator cannot take a frame out, so a moved frame means
    // a new map; the solution settles as the scan goes on (sunset: the frames of the first 30
    // frames' solution end 0.45 degrees from the final one, those of 180 frames' 0.02 in the
    // median), so late in the scan the rebuilds stop.
    // A map of the first kept frames and the orientations they were accumulated with.
    struct KeptMap {
        std::unique_ptr<Engine> engine;
        std::vector<glm::dquat> q;
        // How many calibrations the scan had kept when this map was begun: a map begun before the
        // last one has frames the stale calibration placed, and is never the final map.
        int calibration_generation = 0;
        // Accumulates kept frames q.size() .. n - 1 with orientations `now` (all of them by
        // default), calling after(k) for each.
        void extend(const std::vector<CameraFrame>& frames, const std::vector<glm::dvec3>& w, const CameraCalibration& c,
                    const std::vector<glm::dquat>& now, std::size_t n, const std::function<void(std::size_t)>& after = {}) {
            while (q.size() < n) {
                const std::size_t k = q.size();
                engine->add_frame(frames[k], c, now[k], w[k]);
                q.push_back(now[k]);
                if (after) after(k);
            }
        }
        // The largest angle between the orientations its frames were accumulated with and `now`.
        double deviation_deg(const std::vector<glm::dquat>& now) const {
            double worst = 0;
            for (std::size_t k = 0; k < q.size(); ++k) worst = std::max(worst, angle_between(q[k], now[k]));
            return worst * 180.0 / kPi;
        }
    };
    KeptMap rolling, rebuilding;
    int rebuilds = 0;
    int calibration_generation = 0;  // calibrations kept during the scan
    const auto keep_map = [&](const std::vector<glm::dquat>& qs, std::size_t settled) {
        if (!rolling.engine) rolling = {make_engine(), {}, calibration_generation};
        if (!rebuilding.engine && (rolling.calibration_generation != calibration_generation ||
                                   rolling.deviation_deg(qs) > o.map_rebuild_deg)) {
            rebuilding = {make_engine(), {}, calibration_generation};
            ++rebuilds;
        }
        if (rebuilding.engine) {
            rebuilding.extend(kept, kept_w, cal, qs, std::min(settled, rebuilding.q.size() + std::size_t(std::max(0, o.map_rebuild_per_frame))));
            if (rebuilding.q.size() >= settled) {
                rolling = std::move(rebuilding);
                rebuilding = {};
            }
        }
        // The current map stays complete up to the settled frames while a rebuild runs, so that
        // one unfinished at the end can be dropped.
        rolling.extend(kept, kept_w, cal, qs, settled);
    };
    // The adjustment's own figures from its solve.
    const auto report_adjustment = [&](const AdjustmentResult& r) {
        summary.adjust_pairs = r.pairs_used;
        summary.adjust_pair_rms_deg = r.pair_rms_deg;
        summary.adjust_sensor_rms_deg = r.sensor_rms_deg;
        summary.adjust_drift_deg_per_min = glm::length(r.drift_rate_rad_per_s) * 180.0 / kPi * 60.0;
    };
    // The calibration's refinement as the adjustment found it.
    const auto set_calibration_figures = [&](const AdjustmentResult& r) {
        const double angle = glm::length(r.mounting_rad);
        summary.calibration_mounting_deg = angle * 180.0 / kPi;
        summary.calibration_mounting_axis = angle > 0 ? r.mounting_rad / angle : glm::dvec3(0);
        summary.calibration_time_offset_ms = r.time_offset_s * 1e3;
        summary.calibration_checked = true;
    };
    // The limits of a whole scan's refined solve (the check during the scan has its own).
    const auto stale_after_the_scan = [](const AdjustmentResult& r) {
        return calibration_turn_or_offset_stale(r.calibration_turn_deg, r.time_offset_s * 1e3, kStaleMountingDeg,
                                                kStaleTimeOffsetMs);
    };
    const auto report_calibration = [&](const AdjustmentResult& r) {
        const bool first = !summary.calibration_checked;
        set_calibration_figures(r);
        // The largest turn of the refined solves: the one that decided staleness (an adopted
        // solve turns the frames about as far, and a smaller figure beside "stale" would read as
        // a contradiction).
        summary.calibration_turn_deg =
            first ? r.calibration_turn_deg : std::max(summary.calibration_turn_deg, r.calibration_turn_deg);
        // Stale once any refined solve turned the frames past the limit.
        summary.calibration_stale = summary.calibration_stale || stale_after_the_scan(r);
    };
    // The calibration checked during the scan (CaptureOptions::scan_check_*): a stale one's
    // refined solution kept at once, so that the frame loop's realignments and the kept map's
    // rebuilds take it in while the scan goes on.
    const bool check_during_scan = online && o.calibration_refinement == CaptureOptions::CalibrationRefinement::Stale &&
                                   o.scan_check_from_s > 0;
    double next_scan_check_s = o.scan_check_from_s;
    const auto check_calibration_during_scan = [&](double t_s) {
        if (!check_during_scan || summary.calibration_refined_during_scan_s || t_s < next_scan_check_s) return;
        next_scan_check_s = t_s + std::max(0.0, o.scan_check_every_s);
        const AdjustmentResult refined = online_adjustment.refined_solution();
        summary.calibration_checks_during_scan.push_back({t_s, refined.calibration_turn_deg, refined.time_offset_s * 1e3});
        const bool late = t_s >= o.scan_check_late_from_s;
        const double limit_deg = late ? o.scan_check_late_stale_deg : o.scan_check_stale_deg;
        // No time offset limit before the later limit's start: right calibrations read up to +6.6 ms
        // at 35 s in the quick capture benchmark of 2026-12-07 (+4.7 ms since the sensor path's
        // timing was fixed, 2026-12-08), too near 7.
        const double limit_ms = late ? o.scan_check_late_stale_offset_ms : std::numeric_limits<double>::infinity();
        if (!calibration_turn_or_offset_stale(refined.calibration_turn_deg, refined.time_offset_s * 1e3, limit_deg,
                                              limit_ms))
            return;
        report_calibration(refined);
        online_adjustment.adopt(refined);
        online_adjustment.refine_calibration_from_now();
        ++calibration_generation;
        rebuilding = {};  // its first frames have the stale orientations: the next one starts afresh
        summary.calibration_refined = true;
        summary.calibration_refined_during_scan_s = t_s;
        summary.calibration_turn_during_scan_deg = refined.calibration_turn_deg;
    };
    long long done = 0;
    GuidedCapture guide(o.guided, cal.intrinsics);
    DriftSettings drift_settings;
    drift_settings.gain = o.drift_gain;
    DriftCorrector drift(drift_settings);
    HdrImage live_sphere(o.width, o.height);  // the live map's radiance, kept current where frames look
    // The last two columns, on a simulated session, are the camera-orientation error against the
    // truth before and after the correction (NaN without truth).
    std::string drift_log =
        "index,t_s,pixels,estimate_deg,sigma_deg,residual_before,residual_after,applied,error_before_deg,error_after_deg,"
        "sensor_error_x_deg,sensor_error_y_deg,sensor_error_z_deg\n";
    std::vector<double> drift_angles, drift_before, drift_after;
    double min_exposure = 1e30, max_exposure = 0;
    std::optional<std::int64_t> first_t_ns;
    std::vector<double> blur_px;
    // Every pixel's ray, for straightening rolling-shutter frames (deskewed()).
    // Made at the first frame, once its size is known to be the calibration's (a calibration far
    // larger than the frames asked for gigabytes of rays before any frame was read).
    std::vector<glm::dvec3> pixel_rays;
    const double focal_px = std::max(cal.intrinsics.fx, cal.intrinsics.fy);
    for_each_frame(camera, [&](std::size_t place, const CameraFrame& f) {
        if (!f.is(cal.intrinsics.width, cal.intrinsics.height))
            throw InputError("frame " + std::to_string(f.sequence) + " is " + std::to_string(f.rgb.cols) + "x" +
                             std::to_string(f.rgb.rows) + ", the calibration is for " +
                             std::to_string(cal.intrinsics.width) + "x" + std::to_string(cal.intrinsics.height) +
                             " 8-bit RGB");
        if (!first_t_ns) {
            first_t_ns = f.t_ns;
            if (o.rolling_shutter && cal.readout_s > 0)
                for (int v = 0; v < cal.intrinsics.height; ++v)
                    for (int u = 0; u < cal.intrinsics.width; ++u) pixel_rays.push_back(pixel_ray(cal.intrinsics, u, v));
        }
        std::optional<glm::dquat> q = orientation_of(f);
        glm::dvec3 rate(0);  // the camera's turn (camera frame): the blur, the rows, the time offset
        if (q) {
            rate = angular_velocity_of(f);
            // The blur the frame's exposure must hold: how far the view turned while it was open.
            blur_px.push_back(glm::length(rate) * f.exposure_s * focal_px);
        }
        if (!q) {
            ++summary.frames_without_orientation;
            guide.frame_unplaced(f.t_ns);
        } else if (o.max_blur_px > 0 && blur_px.back() > o.max_blur_px) {
            ++summary.frames_blurred;
        } else {
            const glm::dvec3 w = rows_turn(rate);
            // What the alignments see: the frame as a global shutter would have taken it.
            std::optional<CameraFrame> straight;
            if (!pixel_rays.empty() && w != glm::dvec3(0)) straight = deskew_rolling_shutter(f, cal, pixel_rays, w, threads);
            const CameraFrame& aligned = straight ? *straight : f;
            const glm::dquat sensor_q = *q;
            const auto t_drift = std::chrono::steady_clock::now();
            if (o.drift_correction && acc.frames() > 0) {
                // The CPU merges the exposure bands only where this frame can look (its view plus
                // the largest correction trusted); the GPU path reads the whole map back.
                if (acc.cpu)
                    acc.cpu->update_radiance_in_view(live_sphere, *q, cal.intrinsics,
                                                     drift_settings.max_correction_deg * kPi / 180.0, threads);
                else
                    live_sphere = acc.radiance();
                const DriftEstimate e = drift.estimate(aligned, cal, *q, live_sphere, acc.samples());
                const glm::dquat corrected = unit_rotation((e.applied ? e.correction : drift.carried()) * *q);
                const auto t = true_poses.find(f.sequence);
                const auto err = [&](const glm::dquat& x) {
                    return t == true_poses.end() ? std::nan("") : angle_between(x, t->second) * 180.0 / kPi;
                };
                // The sensor's error as a world-frame rotation vector: truth = exp(error) x sensor.
                glm::dvec3 ev(std::nan(""));
                if (t != true_poses.end()) ev = (180 / kPi) * rotation_vector(t->second * glm::conjugate(*q));
                char line[320];
                std::snprintf(line, sizeof line, "%llu,%.3f,%d,%.4f,%.5f,%.5f,%.5f,%d,%.4f,%.4f,%.4f,%.4f,%.4f\n",
                              static_cast<unsigned long long>(f.sequence), double(f.t_ns - *first_t_ns) * 1e-9,
                              e.pixels, e.angle_deg, e.sigma_deg, e.residual_before, e.residual_after,
                              e.applied ? 1 : 0, err(*q), err(corrected), ev.x, ev.y, ev.z);
                drift_log += line;
                ++summary.drift_considered;
                if (e.applied) {
                    ++summary.drift_applied;
                    drift_angles.push_back(e.angle_deg);
                    drift_before.push_back(e.residual_before);
                    drift_after.push_back(e.residual_after);
                }
                // This frame's correction, or the slow one carried when its estimate was not trusted.
                q = corrected;
            }
            const auto t_acc = std::chrono::steady_clock::now();
            summary.drift_seconds += std::chrono::duration<double>(t_acc - t_drift).count();
            acc.add_frame(f, cal, *q, w);
            used.push_back({place, f.sequence, f.t_ns, sensor_q, *q, rate});
            if (acc.gpu) glFinish();  // the draw's time, not just its submission
            const auto t_online = std::chrono::steady_clock::now();
            summary.accumulate_seconds += std::chrono::duration<double>(t_online - t_acc).count();
            if (online) {
                // This frame's pairs, a solve from the last solution, then the pairs the solution
                // moved most aligned again: the spare time of the frame loop.
                kept.push_back({f.rgb.clone(), f.t_ns, f.exposure_s, f.analogue_gain, f.digital_gain, f.sequence});
                kept_w.push_back(w);
                const double t_scan_s = double(f.t_ns - *first_t_ns) * 1e-9;
                online_adjustment.add_frame(make_alignment_view(aligned, cal), t_scan_s, sensor_q,
                                            *q, rate);
                online_adjustment.solve();
                online_adjustment.realign(o.realign_per_frame, o.realign_deg);
                check_calibration_during_scan(t_scan_s);
                const auto t_map = std::chrono::steady_clock::now();
                const double spent = std::chrono::duration<double>(t_map - t_online).count();
                summary.online_seconds += spent;
                summary.online_max_frame_seconds = std::max(summary.online_max_frame_seconds, spent);
                if (o.keep_map) {
                    const std::size_t n_frames = kept.size(), tail = std::size_t(std::max(0, o.map_tail_frames));
                    keep_map(online_adjustment.orientations(), n_frames > tail ? n_frames - tail : 0);
                    if (acc.gpu) glFinish();
                    const double m = std::chrono::duration<double>(std::chrono::steady_clock::now() - t_map).count();
                    summary.map_seconds += m;
                    summary.map_max_frame_seconds = std::max(summary.map_max_frame_seconds, m);
                }
            }
            const double et = f.exposure_s * f.total_gain();
            min_exposure = std::min(min_exposure, et);
            max_exposure = std::max(max_exposure, et);
            ++summary.frames_used;
            const std::vector<std::uint32_t> samples = acc.samples();
            const GuidedStep g = guide.update(f, *q, samples, o.width, o.height);
            if (o.on_frame) o.on_frame(g, *q, samples);
            summary.guided_too_fast += g.too_fast ? 1 : 0;
            summary.guided_too_bright += g.exposure == ExposureStatus::TooBright ? 1 : 0;
            summary.guided_too_dark += g.exposure == ExposureStatus::TooDark ? 1 : 0;
            summary.guided_final_coverage = g.seeable_coverage;
            if (g.state == GuidedState::Complete && !summary.guided_complete_after_s)
                summary.guided_complete_after_s = g.elapsed_s;
        }
        if (progress) progress(++done, total);
    });
    if (max_exposure > 0) summary.exposure_stops = std::log2(max_exposure / min_exposure);
    const auto median = [](std::vector<double> v) {
        if (v.empty()) return 0.0;
        std::nth_element(v.begin(), v.begin() + std::ptrdiff_t(v.size() / 2), v.end());
        return v[v.size() / 2];
    };
    summary.drift_median_deg = median(drift_angles);
    summary.blur_median_px = median(blur_px);
    if (!blur_px.empty()) summary.blur_max_px = *std::max_element(blur_px.begin(), blur_px.end());
    summary.drift_residual_before = median(drift_before);
    summary.drift_residual_after = median(drift_after);
    if (summary.frames_used == 0)
        throw InputError(o.session.string() + (summary.frames_blurred > 0
                                                   ? ": every frame with an orientation is over --max-blur-px"
                                                   : ": no frame has an orientation"));

    const std::int64_t t_first = first_t_ns.value_or(0);
    // From the last frame of the scan to the finished map (what a visitor waits for).
    const auto t_last_frame = std::chrono::steady_clock::now();
    const auto since = [](std::chrono::steady_clock::time_point a) {
        return std::chrono::duration<double>(std::chrono::steady_clock::now() - a).count();
    };
    // Orientation errors against a simulated session's truth: of the map's orientations, and of
    // the live pass (what the kiosk had while scanning).
    const auto errors = [&](const std::vector<glm::dquat>& qs, std::optional<double>& med, std::optional<double>& max,
                            std::optional<double>& after_60s) {
        std::vector<double> e;
        for (std::size_t i = 0; i < used.size(); ++i) {
            const auto t = true_poses.find(used[i].sequence);
            if (t == true_poses.end()) continue;
            e.push_back(angle_between(qs[i], t->second) * 180.0 / kPi);
            if (used[i].t_ns - t_first >= 60'000'000'000LL) after_60s = std::max(after_60s.value_or(0.0), e.back());
        }
        if (e.empty()) return;
        std::sort(e.begin(), e.end());
        med = e[e.size() / 2];
        max = e.back();
    };
    std::vector<glm::dquat> final_q;
    for (const UsedFrame& u : used) final_q.push_back(u.live);
    std::unique_ptr<Engine> adjusted;  // the map made again from the adjusted orientations
    if (online) {
        // After the last frame: solve, then as in the frame loop, align again the pairs the
        // solution moved most (at most realign_per_frame) and solve, final_realign_passes times.
        // Aligning again everything that moved more than realign_deg took 0.7 s on sunset for
        // 0.006 degrees less error after 60 s (0.250 against 0.256).
        const auto t_adjust = std::chrono::steady_clock::now();
        online_adjustment.solve();
        int passes = 0;
        // Up to max_passes of: the pairs moved more than realign_deg aligned again (at most
        // per_pass; all when negative), then a solve; stops when none moved.
        const auto realign_and_solve = [&](int max_passes, int per_pass, double min_change_deg) {
            for (int pass = 0; pass < max_passes; ++pass, ++passes) {
                if (online_adjustment.realign(per_pass, min_change_deg) == 0) break;
                online_adjustment.solve();
            }
        };
        realign_and_solve(o.final_realign_passes, o.realign_per_frame, o.realign_deg);
        final_q = online_adjustment.orientations();
        const AdjustmentResult& r = online_adjustment.result();
        summary.adjust_pairs_tried = online_adjustment.pairs_tried();
        report_adjustment(r);
        // The camera-sensor calibration checked against the scan: a solve with it refined, kept
        // only when calibration.json is stale (then the whole map is made again below). When the
        // check during the scan kept it already, every solve since refined it: the last one is it.
        const bool refined_during_scan = summary.calibration_refined_during_scan_s.has_value();
        if (refined_during_scan) {
            // Pairs aligned from the stale start are aligned again in the frame loop, 24 a frame;
            // after an adoption near the end of the scan some are left: those that moved more
            // than a tenth of a degree are aligned again now (none, when the loop caught up).
            realign_and_solve(4, -1, std::max(o.realign_deg, o.scan_check_realign_deg));
            final_q = online_adjustment.orientations();
            // The whole scan's solve decides: a partial scan's refinement finds more than a whole
            // one's, so the figures, and staleness, are the last solve's (every solve since the
            // adoption refined the calibration from calibration.json's values).
            const AdjustmentResult& last = online_adjustment.result();
            set_calibration_figures(last);
            summary.calibration_turn_deg = last.calibration_turn_deg;
            summary.calibration_stale = stale_after_the_scan(last);
            report_adjustment(last);
        } else {
            const AdjustmentResult refined = online_adjustment.refined_solution();
            report_calibration(refined);
            const bool keep = o.calibration_refinement == CaptureOptions::CalibrationRefinement::Always ||
                              (o.calibration_refinement == CaptureOptions::CalibrationRefinement::Stale &&
                               summary.calibration_stale);
            summary.calibration_refined = keep;
            if (keep) {
                // The pairs were aligned from orientations the stale calibration put degrees off,
                // and keep part of that start: aligned again from the refined solution, and solved
                // with the refinement, until none moves (mounting about 3 degrees off, courtyard:
                // 2.4 degrees after 60 s with the refined solve alone, 0.09 so).
                online_adjustment.adopt(refined);
                online_adjustment.refine_calibration_from_now();
                realign_and_solve(4, -1, o.realign_deg);
                const AdjustmentResult& adopted = online_adjustment.result();
                report_calibration(adopted);
                final_q = online_adjustment.orientations();
                report_adjustment(adopted);
            }
        }
        summary.adjust_alignments = online_adjustment.alignments();
        summary.adjust_seconds = since(t_adjust);
        char text[160];
        std::snprintf(text, sizeof text, "final passes %d, largest pair change left %.4f deg, %lld alignments in all",
                      passes, online_adjustment.largest_pair_change_deg(), online_adjustment.alignments());
        summary.adjust_profile = text;
        const auto t_final = std::chrono::steady_clock::now();
        const auto count_progress = [&](std::size_t) {
            if (progress) progress(++done, total);
        };
        // A refinement kept after the scan moved every frame: no kept map serves.
        const bool refined_after_scan = summary.calibration_refined && !refined_during_scan;
        // A kept map serves when it was begun after the last calibration kept during the scan and
        // its frames are within map_redo_deg of the final solution.
        const auto near_final = [&](const KeptMap& m) {
            return m.calibration_generation == calibration_generation && m.deviation_deg(final_q) <= o.map_redo_deg;
        };
        if (o.keep_map && rolling.engine && !refined_after_scan) {
            // A rebuild under way is finished when little of it is left, or when the current map
            // cannot serve (begun before a refinement kept during the scan, or too far off); then
            // the held-back tail with the final solution. The map's orientations are
            // what its frames were accumulated with, a little off the final solution where it
            // moved after they were.
            if (rebuilding.engine &&
                (!near_final(rebuilding) ||
                 (near_final(rolling) &&
                  (rolling.deviation_deg(final_q) <= o.map_accept_deg ||
                   rolling.q.size() >= rebuilding.q.size() + std::size_t(std::max(0, o.map_finish_max_frames))))))
                rebuilding = {};
            if (rebuilding.engine) {
                summary.map_final_frames += int(rolling.q.size() - rebuilding.q.size());
                rebuilding.extend(kept, kept_w, cal, final_q, rolling.q.size());
                rolling = std::move(rebuilding);
            }
        }
        if (o.keep_map && rolling.engine && !refined_after_scan && near_final(rolling)) {
            summary.map_deviation_deg = rolling.deviation_deg(final_q);
            summary.map_final_frames += int(kept.size() - rolling.q.size());
            rolling.extend(kept, kept_w, cal, final_q, kept.size(), count_progress);
            // The adjusted solution's own error (the map's is reported below).
            std::optional<double> median_unused, max_unused;
            errors(final_q, median_unused, max_unused, summary.adjusted_after_60s_max_deg);
            summary.map_rebuilds = rebuilds;
            final_q = rolling.q;
            adjusted = std::move(rolling.engine);
        } else {
            // Every frame again (no kept map, the calibration's refinement moved them all, or the
            // kept map is too far off): the kept maps' memory first.
            rolling = {};
            rebuilding = {};
            KeptMap all{make_engine(), {}};
            all.extend(kept, kept_w, cal, final_q, kept.size(), count_progress);
            adjusted = std::move(all.engine);
            summary.map_final_frames = int(kept.size());
            summary.map_rebuilds = rebuilds;
            std::optional<double> median_unused, max_unused;
            errors(final_q, median_unused, max_unused, summary.adjusted_after_60s_max_deg);
        }
        summary.final_accumulate_seconds = since(t_final);
    } else if (adjust) {
        // Global adjustment (global_adjustment.hpp): pairs of overlapping frames aligned to each
        // other, then one pose graph with the sensor and its drift line, in rounds.
        const auto t_adjust = std::chrono::steady_clock::now();
        std::vector<AlignmentView> views(used.size());
        std::vector<double> t_s;
        std::vector<glm::dquat> sensor_q;
        std::size_t next = 0;
        for_each_frame(camera, [&](std::size_t place, const CameraFrame& f) {
            if (next == used.size() || used[next].place != place) return;
            const glm::dvec3 w = row_turn(used[next]);
            views[next] = make_alignment_view(
                !pixel_rays.empty() && w != glm::dvec3(0) ? deskew_rolling_shutter(f, cal, pixel_rays, w, threads) : f, cal);
            t_s.push_back(double(used[next].t_ns - t_first) * 1e-9);
            sensor_q.push_back(used[next].sensor);
            ++next;
            if (progress) progress(++done, total);
        });
        summary.adjust_views_seconds = since(t_adjust);
        const ScanAdjustment sa = adjust_scan(views, t_s, sensor_q, final_q, o.adjustment_rounds, threads, [&] {
            for (std::size_t i = 0; i < used.size(); ++i)
                if (progress) progress(++done, total);
        });
        final_q = sa.result.orientations;
        summary.adjust_pairs_tried = sa.pairs_tried;
        report_adjustment(sa.result);
        summary.adjust_profile = sa.profile;
        summary.adjust_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t_adjust).count();
        const auto t_final = std::chrono::steady_clock::now();
        adjusted = make_engine();
        next = 0;
        for_each_frame(camera, [&](std::size_t place, const CameraFrame& f) {
            if (next == used.size() || used[next].place != place) return;
            adjusted->add_frame(f, cal, final_q[next], row_turn(used[next]));
            ++next;
            if (progress) progress(++done, total);
        });
        summary.final_accumulate_seconds = since(t_final);
    }
    {
        std::vector<glm::dquat> live_q;
        for (const UsedFrame& u : used) live_q.push_back(u.live);
        errors(live_q, summary.live_orientation_error_median_deg, summary.live_orientation_error_max_deg,
               summary.live_orientation_error_after_60s_max_deg);
        errors(final_q, summary.orientation_error_median_deg, summary.orientation_error_max_deg,
               summary.orientation_error_after_60s_max_deg);
    }
    const Engine& map_acc = adjusted ? *adjusted : acc;
    const auto t_radiance = std::chrono::steady_clock::now();
    HdrImage env = map_acc.radiance();
    summary.radiance_seconds = since(t_radiance);
    if (map_acc.cpu) summary.estimated_sources = map_acc.cpu->estimated_sources();
    const std::vector<std::uint32_t> samples =
        samples_with_summed_weight(map_acc.samples(), map_acc.weights(), AccumulationSettings{}.min_weight);
    summary.coverage = measure_coverage(samples, o.width, o.height, o.min_samples);
    const auto t_truth = std::chrono::steady_clock::now();
    if (session.has_truth && fs::exists(truth_env_path(session)))
        summary.truth_error = compare_with_truth(env, samples, o.min_samples, load_exr(truth_env_path(session)).image);
    const double truth_seconds = since(t_truth);  // a measurement, not the appliance's work
    summary.filled_texels = fill_uncovered(env, samples, o.min_samples);
    summary.last_frame_to_map_seconds = since(t_last_frame) - truth_seconds;
    summary.coverage_path = coverage_path_for(o.out);
    // Coverage first: a reader that finds env.exr finds its coverage map too.
    save_exr(summary.coverage_path, coverage_image(samples, map_acc.weights(), o.width, o.height, o.min_samples),
             o.compression);
    try {
        save_exr(o.out, env, o.compression);
    } catch (...) {
        std::error_code ec;  // no coverage map without its map
        fs::remove(summary.coverage_path, ec);
        throw;
    }
    summary.last_frame_to_saved_seconds = since(t_last_frame) - truth_seconds;
    if (std::getenv("GLINT_CAPTURE_PROFILE"))
        std::fprintf(stderr,
                     "profile: last frame -> map %.3f s (saved %.3f s): views %.3f, adjustment %.3f (%s), final "
                     "accumulation %.3f (%d frames), radiance %.3f; over the scan: live drift %.3f s, accumulation "
                     "%.3f s, online adjustment %.3f s (max %.3f s in a frame), map kept %.3f s (max %.3f s), %d "
                     "rebuilds; map off the final solution by %.3f deg, the solution's own error after 60 s %.3f deg\n",
                     summary.last_frame_to_map_seconds, summary.last_frame_to_saved_seconds,
                     summary.adjust_views_seconds, summary.adjust_seconds - summary.adjust_views_seconds,
                     summary.adjust_profile.c_str(), summary.final_accumulate_seconds, summary.map_final_frames,
                     summary.radiance_seconds, summary.drift_seconds, summary.accumulate_seconds,
                     summary.online_seconds, summary.online_max_frame_seconds, summary.map_seconds,
                     summary.map_max_frame_seconds, summary.map_rebuilds, summary.map_deviation_deg,
                     summary.adjusted_after_60s_max_deg.value_or(-1));
    if (std::getenv("GLINT_CAPTURE_PROFILE") && !summary.calibration_checks_during_scan.empty()) {
        std::string checks;
        for (const CaptureSummary::CalibrationCheck& c : summary.calibration_checks_during_scan) {
            char item[64];
            std::snprintf(item, sizeof item, "%s%.1f s %.2f deg %+.1f ms", checks.empty() ? "" : ", ", c.t_s,
                          c.turn_deg, c.time_offset_ms);
            checks += item;
        }
        std::fprintf(stderr, "profile: calibration checks during the scan (turn and time offset of the refined solve): %s\n",
                     checks.c_str());
    }
    if (!o.drift_log.empty()) write_text_atomically(o.drift_log, drift_log);
    if (!o.orientations_out.empty()) {
        std::string csv = camera_poses_csv_header() + "\n";
        for (std::size_t i = 0; i < used.size(); ++i)
            csv += camera_poses_csv_line({used[i].sequence, used[i].t_ns, final_q[i]}) + "\n";
        write_text_atomically(o.orientations_out, csv);
    }
    return summary;
}

bool calibration_turn_or_offset_stale(double turn_deg, double time_offset_ms, double turn_limit_deg,
                                      double offset_limit_ms) {
    // A solve that failed to a NaN or an infinity is no finding, whichever figure it spoiled.
    if (!std::isfinite(turn_deg) || !std::isfinite(time_offset_ms)) return false;
    return turn_deg > turn_limit_deg || std::abs(time_offset_ms) > offset_limit_ms;
}

CameraCalibration calibration_of_scan(const CameraCalibration& file, const CaptureSummary& summary) {
    CameraCalibration c = file;
    if (!summary.calibration_checked || !summary.calibration_refined) return c;
    // The refinement's delta is in the camera frame: world_from_camera = world_from_sensor x
    // sensor_from_camera x exp(delta) (AdjustmentResult::mounting_rad).
    const glm::dvec3 delta = summary.calibration_mounting_axis * (summary.calibration_mounting_deg * kPi / 180.0);
    c.sensor_from_camera = unit_rotation(file.sensor_from_camera * rotation_from_vector(delta));
    c.time_offset_s = file.time_offset_s + summary.calibration_time_offset_ms * 1e-3;
    return c;
}

std::string calibration_check_text(const CaptureSummary& c) {
    if (!c.calibration_checked) return "n/a";
    char text[320];
    if (!c.calibration_stale) {
        std::snprintf(text, sizeof text,
                      "ok: the last scan turned its frames %.2f\xC2\xB0 from the calibration, time offset %+.1f ms "
                      "(limits %.1f\xC2\xB0, %.0f ms)",
                      c.calibration_turn_deg, c.calibration_time_offset_ms, kStaleMountingDeg, kStaleTimeOffsetMs);
        return text;
    }
    std::snprintf(text, sizeof text,
                  "stale: the last scan turned its frames %.2f\xC2\xB0 from the calibration (mounting %.2f\xC2\xB0, time offset "
                  "%+.1f ms; limits %.1f\xC2\xB0, %.0f ms). %s Run the sensor-camera alignment calibration.",
                  c.calibration_turn_deg, c.calibration_mounting_deg, c.calibration_time_offset_ms, kStaleMountingDeg,
                  kStaleTimeOffsetMs,
                  c.calibration_refined ? "Its map and AR view used the scan's own values; the live preview did not."
                                        : "Its map was made with the calibration as it is.");
    return text;
}

}  // namespace glint::capture
