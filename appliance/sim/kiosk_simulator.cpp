#include "appliance/sim/kiosk_simulator.hpp"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <nlohmann/json.hpp>

#include <opencv2/core.hpp>

#include "appliance/capture/kiosk_session.hpp"
#include "appliance/capture/session.hpp"
#include "appliance/core/equirect.hpp"
#include "appliance/core/errors.hpp"
#include "appliance/core/exr_io.hpp"
#include "appliance/core/rotation.hpp"
#include "appliance/sim/camera_simulator.hpp"
#include "appliance/sim/session_writer.hpp"
#include "appliance/tracking/board.hpp"
#include "appliance/tracking/board_print.hpp"
#include "firmware_bridge/host/orientation_history.hpp"

namespace glint::sim {

namespace fs = std::filesystem;
using firmware::sim::TrajectorySample;

namespace {

constexpr double kDeg = kPi / 180.0;

// Printed paper (docs/capture.md "Kiosk sessions"): the white of office paper and the black of
// laser toner, diffuse.
constexpr double kPaperWhite = 0.85, kPaperBlack = 0.04;
// The board's print as the simulator samples it: 4 texels per millimetre (marker edges on texel
// edges, tracking::draw_board), finer than the 2x2 rays of a pixel ever fall on it at 0.4 m
// (0.45 mm apart at 640x360, 0.9 mm at 320x180).
constexpr double kPrintPxPerMm = 4;

// Trajectory samples every 5 ms: the camera's path between them is a slerp (constant rate), so
// the gyro sees the path's rate changes as steps at most 5 ms apart.
constexpr std::uint64_t kStepUs = 5'000;
// Moves between the phases: picking the device up from its stand to the scan's first view, and
// carrying it back to the table while the maps are computed.
constexpr double kPickupS = 1.5, kCarryS = 2.0;
// The button is held this long.
constexpr double kPressS = 0.08;
// The dropout: a visitor's arm in a grey sleeve (about the scene's mean albedo, so that the
// auto-exposure hardly moves) passes between the device and the board, kSleeveDistanceM in front
// of the camera, across its line of sight at kDropoutAt of the AR phase; its speed is chosen so
// that for dropout_s fewer than kTrackableMarkers markers are wholly in view and uncovered (the
// tracker needs 3, docs/tracking.md): the time the tracker cannot see the board.
constexpr double kDropoutAt = 0.55;
constexpr double kSleeveDistanceM = 0.15, kSleeveWidthM = 0.14, kSleeveLengthM = 0.8, kSleeveAlbedo = 0.35;
constexpr int kTrackableMarkers = 3;

double ease(double u) { return 0.5 - 0.5 * std::cos(kPi * std::clamp(u, 0.0, 1.0)); }

firmware::Quatd to_firmware(const glm::dquat& q) {
    const glm::dquat u = unit_rotation(q);
    return {u.w, u.x, u.y, u.z};
}

// world_from_camera of a camera at `from` looking at `to` with world +Y up in the image, rolled
// by `roll_rad` about its view axis (Glint's camera frame: -Z forward, +Y up).
glm::dquat look_at(const glm::dvec3& from, const glm::dvec3& to, double roll_rad) {
    const glm::dvec3 forward = glm::normalize(to - from);
    const glm::dvec3 right = glm::normalize(glm::cross(forward, glm::dvec3(0, 1, 0)));
    const glm::dvec3 up = glm::cross(right, forward);
    const glm::dquat look = glm::quat_cast(glm::dmat3(right, up, -forward));
    return unit_rotation(look * glm::angleAxis(roll_rad, glm::dvec3(0, 0, -1)));
}

// A visitor's arm in a sleeve: a flat strip facing the camera's position at the crossing,
// moving across the line of sight (world frame, metres, camera time in seconds).
struct Sleeve {
    glm::dvec3 centre{0};    // at t_mid
    glm::dvec3 velocity{0};  // along `across`
    glm::dvec3 normal{0, 0, 1}, across{1, 0, 0}, along{0, 1, 0};
    double t_mid = 0, half_width = kSleeveWidthM / 2, half_length = kSleeveLengthM / 2;
    double active_s = 0;  // present for |t - t_mid| <= active_s (well out of the view beyond)

    // Distance along the ray to the sleeve at time t, or nullopt.
    std::optional<double> hit(double t, const glm::dvec3& origin, const glm::dvec3& d) const {
        if (!(std::abs(t - t_mid) <= active_s)) return std::nullopt;
        const glm::dvec3 c = centre + velocity * (t - t_mid);
        const double dn = glm::dot(d, normal);
        if (std::abs(dn) < 1e-9) return std::nullopt;
        const double s = glm::dot(c - origin, normal) / dn;
        if (!(s > 0)) return std::nullopt;
        const glm::dvec3 p = origin + s * d - c;
        if (std::abs(glm::dot(p, across)) > half_width || std::abs(glm::dot(p, along)) > half_length) return std::nullopt;
        return s;
    }
};

// The table and the board on it, lit by the map's irradiance on an upward normal: a diffuse
// surface of albedo a has radiance a E / pi. Both are flat and face up, so one irradiance holds
// everywhere on them (the map is at infinity; the visitor's shadow is not modelled). The sleeve
// is lit the same way (a simplification: its face is nearly vertical).
class KioskScene final : public LocalScene {
public:
    KioskScene(const SimulateKioskOptions& o, const tracking::Board& board, const Rgb& irradiance)
        : height_(o.table_height_m), half_w_(o.table_width_m / 2), half_d_(o.table_depth_m / 2),
          table_albedo_(o.table_albedo), board_half_w_(board.width_m() / 2), board_half_h_(board.height_m() / 2) {
        for (int c = 0; c < 3; ++c) radiance_per_albedo_[c] = double((&irradiance.r)[c]) / kPi;
        const cv::Mat print = tracking::draw_board(board, kPrintPxPerMm);
        print.convertTo(albedo_, CV_32F, (kPaperWhite - kPaperBlack) / 255.0, kPaperBlack);
    }

    // The board frame (docs/tracking.md) in the world: lying face up at the table's centre, its
    // +Y away from the visitor. board +X = world +X, board +Y = world -Z, board +Z = world +Y.
    glm::dquat world_from_board() const { return glm::angleAxis(-0.5 * kPi, glm::dvec3(1, 0, 0)); }
    glm::dvec3 board_centre() const { return {0, height_, 0}; }
    Sleeve sleeve;  // active_s = 0: none

    std::optional<Rgb> radiance(double t, const glm::dvec3& origin, const glm::dvec3& d) const override {
        const std::optional<double> table = table_hit(origin, d);
        const std::optional<double> arm = sleeve.hit(t, origin, d);
        if (arm && (!table || *arm < *table)) return lit(kSleeveAlbedo);
        if (!table) return std::nullopt;
        const glm::dvec3 p = origin + *table * d;
        // Board frame: x = world x, y = -world z (world_from_board above).
        const double bx = p.x, by = -p.z;
        if (std::abs(bx) <= board_half_w_ && std::abs(by) <= board_half_h_) {
            // Print texel centres at integers (tracking::board_to_print, minus half a texel).
            const double k = kPrintPxPerMm * 1000;
            return lit(bilinear((bx + board_half_w_) * k - 0.5, (board_half_h_ - by) * k - 0.5));
        }
        return lit(table_albedo_);
    }

    // Distance along the ray to the table top (seen from above only), or nullopt.
    std::optional<double> table_hit(const glm::dvec3& origin, const glm::dvec3& d) const {
        if (!(d.y < 0) || !(origin.y > height_)) return std::nullopt;
        const double s = (height_ - origin.y) / d.y;
        const glm::dvec3 p = origin + s * d;
        if (std::abs(p.x) > half_w_ || std::abs(p.z) > half_d_) return std::nullopt;
        return s;
    }

private:
    Rgb lit(double albedo) const {
        return {float(albedo * radiance_per_albedo_[0]), float(albedo * radiance_per_albedo_[1]),
                float(albedo * radiance_per_albedo_[2])};
    }
    double bilinear(double u, double v) const {
        u = std::clamp(u, 0.0, double(albedo_.cols - 1));
        v = std::clamp(v, 0.0, double(albedo_.rows - 1));
        const int u0 = std::min(int(u), albedo_.cols - 2), v0 = std::min(int(v), albedo_.rows - 2);
        const double fu = u - u0, fv = v - v0;
        const float* r0 = albedo_.ptr<float>(v0);
        const float* r1 = albedo_.ptr<float>(v0 + 1);
        return (1 - fv) * ((1 - fu) * r0[u0] + fu * r0[u0 + 1]) + fv * ((1 - fu) * r1[u0] + fu * r1[u0 + 1]);
    }

    double height_, half_w_, half_d_, table_albedo_, board_half_w_, board_half_h_;
    double radiance_per_albedo_[3] = {0, 0, 0};
    cv::Mat albedo_;  // the print's albedo, CV_32F
};

// The camera's path over the whole visit, in camera time from the first attract frame.
struct KioskPath {
    double press_s = 0;            // the button press
    double scan_start_s = 0, scan_end_s = 0;
    double ar_start_s = 0, ar_end_s = 0;
    glm::dvec3 stand{0};           // where the device rests during attract
    glm::dquat stand_view{1, 0, 0, 0};
    const firmware::sim::Trajectory* scan = nullptr;  // the guided scan from its own time 0
    glm::dvec3 board{0};           // the board's centre

    // The AR phase: an orbit round the board at a walker's pace, whatever the phase's length:
    // from the visitor's left to the right through up to 70 degrees at 6 deg/s on average,
    // 0.36-0.60 m out and 0.28-0.56 m up (0.45-0.82 m from the board's centre) over a 12 s
    // cycle, the aim wandering 3 cm about the centre and the camera rolling +-4 degrees.
    static constexpr double kCycleS = 12;
    glm::dvec3 ar_position(double t) const {
        const double len = ar_end_s - ar_start_s, tau = std::clamp(t - ar_start_s, 0.0, len);
        const double sweep = std::min(70.0, 6 * len);
        const double a = (-0.5 * sweep + sweep * ease(tau / len)) * kDeg;
        const double r = 0.48 + 0.12 * std::sin(2 * kPi * tau / kCycleS);
        const double h = 0.42 + 0.14 * std::sin(3 * kPi * tau / kCycleS + 0.5);
        return board + glm::dvec3(r * std::sin(a), h, r * std::cos(a));
    }
    glm::dquat ar_view(double t) const {
        const double tau = std::clamp(t - ar_start_s, 0.0, ar_end_s - ar_start_s) / kCycleS;
        const glm::dvec3 aim = board + glm::dvec3(0.03 * std::sin(5 * tau), 0, 0.03 * std::cos(4 * tau));
        return look_at(ar_position(t), aim, 4 * kDeg * std::sin(1.6 * kPi * tau));
    }
    // On the stand until the device is picked up; from the scan on (whose frames see no table)
    // the AR orbit's, which holds its first point until the AR phase begins: the first AR
    // frame's early rows (rolling shutter) are exposed a little before it.
    glm::dvec3 position(double t) const { return t < scan_start_s ? stand : ar_position(t); }

    glm::dquat view(double t) const {
        const glm::dquat scan_first = host::to_glm(scan->at(0).world_from_sensor);
        const glm::dquat scan_last = host::to_glm(scan->at(scan->end_us()).world_from_sensor);
        if (t <= press_s) return stand_view;
        if (t < scan_start_s) return glm::slerp(stand_view, scan_first, ease((t - press_s) / (scan_start_s - press_s)));
        if (t <= scan_end_s) return host::to_glm(scan->at(std::uint64_t(std::llround((t - scan_start_s) * 1e6))).world_from_sensor);
        const glm::dquat ar_first = ar_view(ar_start_s);
        if (t < ar_start_s) return glm::slerp(scan_last, ar_first, ease((t - scan_end_s) / (ar_start_s - scan_end_s)));
        return ar_view(t);
    }
};

// Can the tracker see the board at time t: are kTrackableMarkers markers wholly in the image
// (their four corners) and uncovered by the sleeve (which is wider than a marker, so a marker
// whose corners it misses it misses)?
bool board_in_view(const capture::Intrinsics& k, const tracking::Board& board, const KioskScene& scene,
                   const KioskPath& path, double t) {
    const glm::dquat camera_from_world = glm::conjugate(path.view(t));
    const glm::dvec3 position = path.position(t);
    int seen = 0;
    for (int i = 0; i < board.marker_count(); ++i) {
        bool whole = true;
        for (const cv::Point3f& c : board.corners(i)) {
            const glm::dvec3 w = scene.board_centre() + scene.world_from_board() * glm::dvec3(c.x, c.y, c.z);
            const double distance = glm::length(w - position);
            const std::optional<double> arm = scene.sleeve.hit(t, position, (w - position) / distance);
            if (!capture::project(k, camera_from_world * (w - position), 0.0) || (arm && *arm < distance)) {
                whole = false;
                break;
            }
        }
        if (whole && ++seen >= kTrackableMarkers) return true;
    }
    return false;
}

// The span of camera time (first, last) in [t0, t1] during which the tracker cannot see the
// board (board_in_view), sampled every ms; (-1, -1) when there is none.
std::pair<double, double> hidden_span(const capture::Intrinsics& k, const tracking::Board& board,
                                      const KioskScene& scene, const KioskPath& path, double t0, double t1) {
    double first = -1, last = -1;
    for (double t = t0; t <= t1; t += 1e-3)
        if (!board_in_view(k, board, scene, path, t)) {
            if (first < 0) first = t;
            last = t;
        }
    return {first, last};
}

std::string board_json(const tracking::BoardSpec& s) {
    nlohmann::ordered_json j;
    j["columns"] = s.columns;
    j["rows"] = s.rows;
    j["marker_mm"] = s.marker_mm;
    j["gap_mm"] = s.gap_mm;
    j["margin_mm"] = s.margin_mm;
    j["dictionary"] = s.dictionary;
    j["first_id"] = s.first_id;
    return j.dump();
}

void write_text(const fs::path& p, const std::string& text) {
    std::ofstream out(p);
    out << text;
    if (!out.flush()) throw RuntimeError(p.string() + ": cannot write");
}

std::uint64_t to_us(double t_s) { return std::uint64_t(std::llround(t_s * 1e6)); }
// Phase boundaries on the trajectory's 5 ms grid, so that each move starts on a sample.
double on_grid(double t_s) { return double(to_us(t_s) / kStepUs * kStepUs) * 1e-6; }

void check(const SimulateKioskOptions& o) {
    if (o.material_presses < 0 || o.material_presses > 20) throw InputError("kiosk session: material_presses must be 0 to 20");
    const auto in = [](double v, double lo, double hi) { return v >= lo && v <= hi; };
    if (!in(o.attract_s, 0.5, 600) || !in(o.attract_fps, 0.5, 60)) throw InputError("kiosk: attract must be 0.5..600 s at 0.5..60 fps");
    if (!in(o.scan_speed_deg_s, 5, 180)) throw InputError("kiosk: the scan's speed must be 5..180 deg/s");
    if (!in(o.scan_fps, 0.5, 60)) throw InputError("kiosk: the scan's frame rate must be 0.5..60 fps");
    if (!in(o.ar_s, 1, 600) || !in(o.ar_fps, 1, 60)) throw InputError("kiosk: the AR phase must be 1..600 s at 1..60 fps");
    if (!in(o.dropout_s, 0, 0.25 * o.ar_s)) throw InputError("kiosk: the dropout must be 0..a quarter of the AR phase");
    if (!in(o.heading_drift_deg_per_min, -60, 60)) throw InputError("kiosk: the heading drift must be within +-60 deg/min");
    if (!in(o.table_height_m, 0.3, 1.5) || !in(o.table_width_m, 0.4, 4) || !in(o.table_depth_m, 0.4, 4))
        throw InputError("kiosk: the table must be 0.3..1.5 m high and 0.4..4 m wide and deep");
    if (!in(o.table_albedo, 0, 1)) throw InputError("kiosk: the table's albedo must be in 0..1");
}

}  // namespace

Rgb irradiance_up(const HdrImage& env) {
    // Row j spans polar angles theta0..theta1 from +Y (row 0 at the top); a texel of it, of
    // azimuth width 2 pi / W, gathers integral cos(theta) d(omega) = (pi / W)(sin^2 theta1 -
    // sin^2 theta0), clipped at the horizon: exact for a map that is constant over each texel.
    const int w = env.width(), h = env.height();
    double sum[3] = {0, 0, 0};
    for (int j = 0; j < h; ++j) {
        const double theta0 = kPi * j / h, theta1 = std::min(kPi * (j + 1) / h, 0.5 * kPi);
        if (theta0 >= 0.5 * kPi) break;
        const double weight = kPi / w * (std::pow(std::sin(theta1), 2) - std::pow(std::sin(theta0), 2));
        const float* row = env.row(j);
        for (int i = 0; i < w; ++i)
            for (int c = 0; c < 3; ++c) sum[c] += weight * row[3 * i + c];
    }
    return {float(sum[0]), float(sum[1]), float(sum[2])};
}

KioskSummary simulate_kiosk_session(const SimulateKioskOptions& ko,
                                    const std::function<void(long long, long long)>& progress) {
    check(ko);
    SimulateOptions o;
    o.env = ko.env;
    o.out = ko.out;
    o.overwrite = ko.overwrite;
    o.seed = ko.seed;
    o.threads = ko.threads;
    o.width = ko.width;
    o.height = ko.height;
    o.horizontal_fov_deg = ko.horizontal_fov_deg;
    o.frame_format = ko.frame_format;
    o.jpeg_quality = ko.jpeg_quality;
    o.camera_noise = ko.camera_noise;
    o.guided_speed_deg_s = ko.scan_speed_deg_s;
    o.heading_drift_deg_per_min = ko.heading_drift_deg_per_min;
    o.hdr_bracket = true;
    o.fps = ko.scan_fps;
    detail::check_common_options(o);
    LoadedExr loaded = load_exr(o.env);
    if (ko.on_environment) ko.on_environment(loaded);
    const HdrImage env = std::move(loaded.image);

    const tracking::Board board;  // tracking's default board
    KioskSummary summary;
    const Rgb e = irradiance_up(env);
    summary.irradiance_up[0] = e.r;
    summary.irradiance_up[1] = e.g;
    summary.irradiance_up[2] = e.b;
    if (!(e.r + e.g + e.b > 0)) throw InputError(o.env.string() + ": the map sends no light onto the table");
    KioskScene scene(ko, board, e);
    const capture::Intrinsics k = detail::true_camera(o).intrinsics;

    // --- the path ---
    const firmware::sim::Trajectory scan(guided_camera_trajectory(ko.scan_speed_deg_s));
    KioskPath path;
    path.scan = &scan;
    path.board = scene.board_centre();
    // The stand: 0.55 m in front of the board's centre (on the visitor's side) and 0.35 m up.
    path.stand = path.board + glm::dvec3(0, 0.35, 0.55);
    path.stand_view = look_at(path.stand, path.board, 0);
    path.press_s = on_grid(ko.attract_s);
    path.scan_start_s = on_grid(path.press_s + kPickupS);
    path.scan_end_s = path.scan_start_s + double(scan.end_us()) * 1e-6;
    path.ar_start_s = on_grid(path.scan_end_s + kCarryS);
    path.ar_end_s = path.ar_start_s + ko.ar_s;
    if (ko.dropout_s > 0) {
        // The sleeve crosses the line of sight from the camera to the board's centre at t_mid,
        // kSleeveDistanceM from the camera, moving to the camera's right; the slower it moves,
        // the longer it hides the board: its speed by bisection (the hidden span shrinks as the
        // speed grows) so that the tracker cannot see the board for dropout_s.
        Sleeve& arm = scene.sleeve;
        arm.t_mid = path.ar_start_s + kDropoutAt * ko.ar_s;
        const glm::dvec3 p = path.position(arm.t_mid);
        const glm::dvec3 f = glm::normalize(path.board - p);
        arm.normal = -f;
        arm.across = glm::normalize(glm::cross(f, glm::dvec3(0, 1, 0)));
        arm.along = glm::cross(arm.across, arm.normal);
        arm.centre = p + kSleeveDistanceM * f;
        const auto span_at = [&](double speed) {
            arm.velocity = speed * arm.across;
            // Well out of the view (+-35 degrees at kSleeveDistanceM is +-0.1 m) beyond +-0.6 m.
            arm.active_s = 0.6 / speed;
            const auto [a, b] = hidden_span(k, board, scene, path, arm.t_mid - 1.0, arm.t_mid + 1.0);
            return a < 0 ? 0.0 : b - a;
        };
        double lo = 0.02, hi = 3.0;
        if (span_at(lo) < ko.dropout_s) throw InputError("kiosk: the sleeve cannot hide the board for the dropout");
        for (int i = 0; i < 30; ++i) {
            const double mid = 0.5 * (lo + hi);
            (span_at(mid) >= ko.dropout_s ? lo : hi) = mid;
        }
        span_at(lo);
        const auto [a, b] = hidden_span(k, board, scene, path, arm.t_mid - 1.0, arm.t_mid + 1.0);
        summary.dropout_start_s = a;
        summary.dropout_end_s = b;
        summary.dropout_start_ns = detail::appliance_time_ns(o, to_us(a));
        summary.dropout_end_ns = detail::appliance_time_ns(o, to_us(b));
        summary.sleeve_speed_m_s = lo;
    }
    std::vector<TrajectorySample> samples;
    const std::uint64_t end_us = to_us(path.ar_end_s + 0.5);
    for (std::uint64_t t = 0; t <= end_us; t += kStepUs) samples.push_back({t, to_firmware(path.view(double(t) * 1e-6))});
    const firmware::sim::Trajectory camera(samples);

    // --- the segments ---
    detail::SessionPlan plan;
    plan.camera = &camera;
    plan.created_by = "glint simulate --kiosk";
    // truth/env.exr is a copy of the map's file, not the loaded map saved as float (courtyard:
    // 0.27 MB against 3.5 MB; the shipped session must fit in 15 MB). load_exr reads the copy to
    // exactly the map the frames were rendered from: it sanitises (NaN, Inf, negatives) the same
    // way every time.
    plan.env_file = o.env;
    const auto position = [&path](double t_s) { return path.position(t_s); };
    detail::SessionSegment attract;
    attract.start_us = 0;
    attract.fps = ko.attract_fps;
    attract.frames = std::max(1, int(std::floor(ko.attract_s * ko.attract_fps - 1e-9)) + 1);
    while (attract.frames > 1 && double(attract.frames - 1) / ko.attract_fps >= path.press_s) --attract.frames;
    attract.scene = &scene;
    attract.position = position;
    detail::SessionSegment scan_segment;
    scan_segment.start_us = to_us(path.scan_start_s);
    scan_segment.fps = ko.scan_fps;
    scan_segment.frames = int(std::floor(double(scan.end_us()) * 1e-6 * ko.scan_fps)) + 1;
    scan_segment.hdr_bracket = true;
    detail::SessionSegment ar;
    ar.start_us = to_us(path.ar_start_s);
    ar.fps = ko.ar_fps;
    ar.frames = int(std::floor(ko.ar_s * ko.ar_fps - 1e-9)) + 1;
    ar.scene = &scene;
    ar.position = position;
    plan.segments = {attract, scan_segment, ar};

    const tracking::BoardSpec spec = board.spec();
    plan.finish = [&](const fs::path& partial, const std::vector<detail::WrittenFrame>& frames) {
        const auto t_ns = [&](double t_s) { return detail::appliance_time_ns(o, to_us(t_s)); };
        // Events: the press that starts the scan, and its release.
        std::string events = capture::session_events_csv_header() + "\n";
        events += capture::session_events_csv_line({t_ns(path.press_s), "button", "press"}) + "\n";
        events += capture::session_events_csv_line({t_ns(path.press_s + kPressS), "button", "release"}) + "\n";
        // The visitor tries the materials while looking at the object.
        for (int press = 0; press < ko.material_presses; ++press) {
            const double t = path.ar_start_s + (press + 1) * ko.ar_s / (ko.material_presses + 1);
            events += capture::session_events_csv_line({t_ns(t), "button", "press"}) + "\n";
            events += capture::session_events_csv_line({t_ns(t + kPressS), "button", "release"}) + "\n";
        }
        write_text(partial / "events.csv", events);

        // The true camera_from_board of every AR frame, in OpenCV's camera frame (a half turn
        // about X from Glint's: conventions.md "Camera frame and pixels").
        const glm::dquat opencv_from_glint(0, 1, 0, 0);
        std::string truth = capture::truth_board_csv_header() + "\n";
        std::int64_t last_scan_ns = 0, first_ar_ns = -1, last_ar_ns = 0, first_ns = frames.front().t_ns;
        for (const detail::WrittenFrame& f : frames) {
            if (f.segment == 0) ++summary.attract_frames;
            if (f.segment == 1) {
                ++summary.scan_frames;
                last_scan_ns = f.t_ns;
            }
            if (f.segment != 2) continue;
            ++summary.ar_frames;
            if (first_ar_ns < 0) first_ar_ns = f.t_ns;
            last_ar_ns = f.t_ns;
            const glm::dquat camera_from_world = opencv_from_glint * glm::conjugate(f.world_from_camera);
            capture::TruthBoardPose p;
            p.index = f.index;
            p.t_ns = f.t_ns;
            p.camera_from_board = unit_rotation(camera_from_world * scene.world_from_board());
            p.t_m = camera_from_world * (path.board - path.position(double(f.tc_us) * 1e-6));
            truth += capture::truth_board_csv_line(p) + "\n";
        }
        write_text(partial / "truth" / "board.csv", truth);

        capture::KioskSessionInfo info;
        const std::int64_t press_ns = t_ns(path.press_s);
        const std::int64_t scan_frame_ns = std::llround(1e9 / ko.scan_fps), ar_frame_ns = std::llround(1e9 / ko.ar_fps);
        info.phases = {{"attract", first_ns, press_ns},
                       {"scan", press_ns, last_scan_ns + scan_frame_ns},
                       {"ar", first_ar_ns, last_ar_ns + ar_frame_ns}};
        info.board_json = board_json(spec);
        info.table_height_m = ko.table_height_m;
        info.world_from_board = scene.world_from_board();
        info.world_board_t = path.board;
        write_text(partial / "kiosk.json", capture::kiosk_json(info));
    };
    summary.session = detail::write_planned_session(o, env, plan, progress);
    return summary;
}

}  // namespace glint::sim
