#include "appliance/ui/kiosk_loop.hpp"

#include "appliance/core/memory.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <future>
#include <sstream>
#include <unistd.h>
#include <memory>
#include <optional>
#include <thread>

#include <GLES3/gl32.h>
#include <opencv2/imgproc.hpp>

#include "appliance/capture/capture_pipeline.hpp"
#include "appliance/capture/kiosk_session.hpp"
#include "appliance/capture/session.hpp"
#include "appliance/core/atomic_file.hpp"
#include "appliance/core/equirect.hpp"
#include "appliance/core/error_metrics.hpp"
#include "appliance/core/errors.hpp"
#include "appliance/core/exr_io.hpp"
#include "appliance/core/parallel.hpp"
#include "appliance/core/rotation.hpp"
#include "appliance/core/scene_state.hpp"
#include "appliance/gl/display.hpp"
#include "appliance/gl/png_writer.hpp"
#include "appliance/render/camera_response.hpp"
#include "appliance/render/live_maps.hpp"
#include "appliance/render/maps.hpp"
#include "appliance/render/material.hpp"
#include "appliance/render/mesh.hpp"
#include "appliance/render/renderer.hpp"
#include "appliance/render/shadow.hpp"
#include "appliance/render/shadow_bake.hpp"
#include "appliance/tracking/board.hpp"
#include "appliance/tracking/board_view.hpp"
#include "appliance/tracking/tracker.hpp"
#include "appliance/ui/ar_camera.hpp"
#include "appliance/ui/capture_job.hpp"
#include "appliance/ui/frame_scheduler.hpp"
#include "appliance/ui/image_quad.hpp"
#include "appliance/ui/kiosk_flow.hpp"
#include "appliance/ui/lens_undistortion.hpp"

namespace glint::ui {
namespace fs = std::filesystem;
using json = nlohmann::json;
using WallClock = std::chrono::steady_clock;

namespace {

double seconds_since(WallClock::time_point t) { return std::chrono::duration<double>(WallClock::now() - t).count(); }

// How long this process has run (seconds, 10 ms steps): /proc/uptime minus the process's start
// in /proc/self/stat (field 22, clock ticks after boot). -1 when either cannot be read.
double process_age_s() {
    std::ifstream uptime_file("/proc/uptime"), stat_file("/proc/self/stat");
    double uptime = 0;
    std::string stat;
    if (!(uptime_file >> uptime) || !std::getline(stat_file, stat)) return -1;
    // The command name (field 2) may hold spaces: count fields after its closing parenthesis.
    const std::size_t close = stat.rfind(')');
    if (close == std::string::npos) return -1;
    std::istringstream rest(stat.substr(close + 2));
    std::string field;
    for (int k = 3; k <= 22 && rest >> field; ++k)
        if (k == 22) return uptime - std::stod(field) / double(sysconf(_SC_CLK_TCK));
    return -1;
}

// The material behind a config name: "matte", "glossy:N", "mirror" or a full spec; the screen's
// string key is "material." + the name before any ':'.
std::string material_key(const std::string& name) { return "material." + name.substr(0, name.find(':')); }

// The size of the room's preview, the picture PROCESSING shows once the map is read.
constexpr int kPreviewWidth = 256, kPreviewHeight = 128;

// An HDR map as an 8-bit picture (Reinhard on luminance, sRGB-ish gamma): the processing screen's
// preview of the room just captured.
cv::Mat preview_of(const HdrImage& env, int width, int height) {
    cv::Mat out(height, width, CV_8UC3);
    double log_sum = 0;
    for (int j = 0; j < env.height(); ++j)
        for (int i = 0; i < env.width(); ++i) {
            const Rgb c = env.at(i, j);
            log_sum += std::log(1e-4 + 0.2126 * c.r + 0.7152 * c.g + 0.0722 * c.b);
        }
    const double scale = 0.18 / std::exp(log_sum / double(env.texel_count()));
    for (int y = 0; y < height; ++y)
        for (int x = 0; x < width; ++x) {
            const Rgb c = env.at(x * env.width() / width, y * env.height() / height);
            const double v[3] = {c.r * scale, c.g * scale, c.b * scale};
            for (int k = 0; k < 3; ++k)
                out.at<cv::Vec3b>(y, x)[k] = std::uint8_t(std::lround(255.0 * std::pow(v[k] / (1 + v[k]), 1 / 2.2)));
        }
    return out;
}

// What PROCESSING makes on a worker once the capture is done.
struct NewScene {
    HdrImage env;
    cv::Mat preview;
    render::ShadingMaps maps;
};

// The object's shadow on the table for one room (docs/kiosk.md, "Shadows"): the room's dominant
// lights, the mesh's occluder spheres, and for a mesh that is not a single sphere the shadow baked
// against the mesh with Embree rays. Made on a worker; the renderer takes it on the frame thread.
struct SceneShadow {
    render::ShadowLighting lighting;
    std::vector<render::OccluderSphere> occluders;
    std::optional<render::ShadowBake> bake;
    double seconds = 0;
};

SceneShadow make_scene_shadow(const HdrImage& room, const render::Mesh& mesh,
                              const std::vector<render::OccluderSphere>& occluders, double table_height, int threads) {
    const auto t0 = WallClock::now();
    SceneShadow s;
    s.lighting = render::shadow_lighting(room);
    s.occluders = occluders;
    if (s.occluders.size() != 1) {
        render::ShadowBakeOptions options;
        options.threads = threads;
        s.bake = render::bake_table_shadow(mesh, s.lighting, table_height, options);
    }
    s.seconds = seconds_since(t0);
    return s;
}

constexpr std::size_t kMaxStatesKept = 4096;

json frame_times_json(const FrameTimes& t) { return {{"median", t.median()}, {"p99", t.p99()}, {"max", t.max()}, {"frames", t.count}}; }

}  // namespace

gl::DisplayConfig display_config_of(const Config& cfg) {
    gl::DisplayConfig d;
    d.kind = cfg.display.kind;
    d.card = cfg.display.card;
    d.connector = cfg.display.connector;
    d.mode = cfg.display.mode;
    d.kms_api = cfg.display.kms_api;
    d.width = cfg.display.width;
    d.height = cfg.display.height;
    d.fullscreen = cfg.display.fullscreen;
    d.vt = cfg.display.vt;
    d.vt_lock_switch = cfg.display.vt_lock_switch;
    d.vt_switch = cfg.display.vt_switch;
    d.keyboard = cfg.display.keyboard;
    return d;
}

KioskResult run_kiosk(KioskSource& source, const KioskOptions& o, const std::function<void(const std::string&)>& log) {
    const WallClock::time_point process_start = WallClock::now();
    Config cfg = o.config;
    const std::int64_t t0_ns = source.start_ns();
    const auto kiosk_s = [&](std::int64_t t_ns) { return double(t_ns - t0_ns) * 1e-9; };
    // After a restart ATTRACT shows the last visitor's scene if it verifies (docs/state.md); a
    // faulty one is set aside and logged. Before maps_dir is made: a damaged item may be in its way.
    const std::optional<HdrImage> last_scene = source.replayed() ? std::nullopt : load_last_scene(o.maps_dir, log);
    source.set_lamp(LampMode::Blink);  // a press is taken from now on (it waits for the first frame)
    std::error_code ec;
    for (const fs::path& dir : {o.maps_dir, o.frames_dir}) {
        if (dir.empty()) continue;
        fs::create_directories(dir, ec);
        if (ec) throw InputError(dir.string() + ": cannot create it: " + ec.message());
    }

    // Display and GL: headless unless the config says otherwise.
    const gl::DisplayConfig display_config = display_config_of(cfg);
    std::unique_ptr<gl::Display> own_display;
    gl::Display* display = o.display;
    if (!display) {
        std::vector<gl::DisplayAttempt> attempts;
        own_display = gl::open_display(display_config, &attempts);
        display = own_display.get();
        for (const gl::DisplayAttempt& a : attempts)
            log(std::string("display ") + gl::display_kind_name(a.kind) + ": " + (a.ok ? "opened " : "not opened: ") + a.detail);
    }
    const int width = display->width(), height = display->height();

    // The object, its materials and a renderer per material, lit at first by the last scene or,
    // without one (a new appliance, a replay, a scene that did not verify), a neutral grey room.
    std::vector<render::Material> materials;
    for (const std::string& name : cfg.ar.materials) materials.push_back(render::parse_material(name, "ar.materials"));
    if (materials.empty()) throw InputError("ar.materials: the list is empty");
    const render::Mesh mesh = render::load_model(cfg.ar.model, "ar.model");
    HdrImage grey(64, 32);
    std::fill(grey.data().begin(), grey.data().end(), 0.5f);
    // Shared with the renderer (Renderer::replace_maps): new maps are moved in, never copied.
    std::shared_ptr<const render::ShadingMaps> maps =
        std::make_shared<const render::ShadingMaps>(render::coarse_maps(last_scene ? *last_scene : grey, materials, 1));
    // One renderer; the button changes its material (its shaders are compiled once).
    // The 3D view is drawn at the camera's resolution (at most the display's) and stretched over
    // the display: the object gets the pixel footprint of the real scene around it (a sharper
    // object than its surroundings looks pasted on), and the GPU shades a fraction of the pixels.
    const int view_width = std::min(width, source.calibration().intrinsics.width);
    const int view_height = std::min(height, source.calibration().intrinsics.height);
    render::Renderer renderer(mesh, materials.front(), *maps, view_width, view_height);
    ViewTarget view(view_width, view_height);
    renderer.set_table(render::model_bottom(mesh));  // the table hides what is under it
    int renderer_material = 0;
    const render::CameraResponse& response = source.response();
    const capture::CameraCalibration& cal = source.calibration();
    // The AR background: the camera's picture remapped to the renderer's pinhole.
    const LensUndistortion lens(cal.intrinsics);
    gl::RgbImage background_upload;  // the newest picture, undistorted (its buffer reused frame to frame)
    bool background_stale = true;       // a new picture since the last upload
    bool camera_background_set = false; // the renderer's background is the camera's picture
    ArPlacement placement;
    placement.object_radius_m = cfg.ar.object_radius_m;
    placement.model_bottom = render::model_bottom(mesh);

    // Tracking: the session's board (the default one without a kiosk recording).
    const std::string board_json = source.board_json();
    const tracking::Board board(board_json.empty() ? tracking::BoardSpec{}
                                                   : tracking::board_spec_from_json(board_json, source.describe() + ": board"));
    // The mounting and time offset the AR view uses: calibration.json's, or those of the scan
    // whose map is shown when it found the file stale (capture::calibration_of_scan), so that the
    // map's light stays where the scan put it relative to the camera.
    glm::dquat ar_sensor_from_camera = cal.sensor_from_camera;
    double ar_time_offset_s = cal.time_offset_s;
    // The tracker's mounting is in OpenCV's camera frame; made again when the AR's changes.
    const auto make_tracker = [&] {
        return std::make_unique<tracking::Tracker>(board, tracking_camera(cal.intrinsics),
                                                   glm::normalize(ar_sensor_from_camera * kGlFromCv));
    };
    std::unique_ptr<tracking::Tracker> tracker = make_tracker();

    ImageQuad picture;
    KioskOptions::Overlay overlay = o.make_overlay ? o.make_overlay(width, height) : KioskOptions::Overlay{};
    KioskFlow flow(cfg.timeouts, int(materials.size()), 0.0);
    FrameScheduler scheduler(cfg.frame.budget_ms, cfg.frame.hard_cap_ms, /*keep_records=*/!o.frame_log.empty());
    const int threads = o.threads > 0 ? o.threads : std::max(1, hardware_threads() - 1);

    // The visitor's scene.
    std::unique_ptr<CaptureJob> capture_job;
    std::optional<capture::CaptureSummary> capture_summary;
    // The last scan's check of the camera-sensor calibration, for the status page (it outlives
    // the visit: a knocked camera stays knocked).
    std::string alignment_text = "n/a";
    bool alignment_stale = false;
    std::future<NewScene> scene_job;
    std::vector<std::future<NewScene>> abandoned_scenes;  // a timed-out visit's job, left to finish
    std::shared_ptr<const HdrImage> env;  // this visit's room (shared with the background jobs)
    double scan_end_wall_s = -1, lit_wall_s = -1, final_maps_wall_s = -1;
    std::string scan_end_reason;
    bool have_scene = last_scene.has_value();  // a lit scene for ATTRACT to show
    bool attract_background_set = false;  // the renderer's background is the room now
    bool scene_requested = false;          // this visit's scene job has been started
    // The shadow of the room the object is lit by: one bake at a time; a newer room waits for it.
    // The mesh's occluder spheres: the mesh does not change, so voxelised once for every room.
    const std::vector<render::OccluderSphere> occluders = render::occluder_spheres(mesh);
    std::future<SceneShadow> shadow_job;
    // Rooms are shared, not copied: a copy of a 1024x512 map in the frame the scene arrived cost
    // that frame 5 ms for the final maps' job and 23 ms for the shadow's.
    std::shared_ptr<const HdrImage> shadow_next;
    const auto start_shadow = [&](std::shared_ptr<const HdrImage> room) {
        if (!cfg.ar.shadows) return;
        if (shadow_job.valid()) {
            shadow_next = std::move(room);  // after the running bake (a future from std::async blocks when dropped)
            return;
        }
        shadow_job = std::async(std::launch::async, [room = std::move(room), &mesh, &occluders, table = render::model_bottom(mesh), threads] {
            // Background work, like the final maps: it starts in the frame that enters AR, and at
            // the frames' priority it took the cores from the first AR frames (one took 138 ms).
            lower_this_thread_priority();
            return make_scene_shadow(*room, mesh, occluders, table, threads);
        });
    };
    if (last_scene) start_shadow(std::make_shared<const HdrImage>(*last_scene));

    // What the replay measures.
    json states = json::array();
    states.push_back({{"name", kiosk_state_name(KioskState::Attract)}, {"t_s", 0.0}});
    int ar_frames = 0, ar_detected = 0;
    std::vector<double> ar_rotation_error_deg;
    std::vector<double> ar_camera_error_deg;  // see summary.json's ar_camera_orientation_error_deg
    double first_frame_s = -1;

    double period_s = cfg.frame.budget_ms * 1e-3;
    double t_s = 0, last_snapshot_s = -1e9;
    cv::Mat last_rgb;
    capture::CameraFrame last_frame;
    bool new_picture = false;
    std::optional<tracking::TrackResult> last_track;
    // The pose tracked before last_track's, and both pictures' times: the object's motion blur.
    std::optional<tracking::Pose> pose_before;
    std::int64_t pose_before_t_ns = 0, pose_t_ns = 0;
    int frame_no = 0;
    // One frame of every kind drawn before the clock starts: the driver compiles and allocates on
    // first use, which no visitor frame should pay. A software rasteriser (llvmpipe) compiles a
    // shader again for every new combination of the textures bound to it (their formats, and
    // whether each side is a power of two), so the warm-up binds what the frames will bind:
    // - the camera's response first (the frames always go through it once it is set);
    // - both backgrounds, the room at the captured map's size (ATTRACT) and the camera's picture
    //   at the camera's size (AR): an 8x8 picture left a 760 ms first AR frame;
    // - the shadow (docs/kiosk.md, "Shadows") without and with a baked part: the grey room's
    //   (no dominant light, the contact shadow of the object's spheres) until a room's own is
    //   made, and a bake of the real bake's size that hides nothing (the first frame after the
    //   room's bake arrived took 0.9 s before).
    renderer.set_camera_response(response, {10.0, 1.0});
    const int picture_width = std::max(1, cal.intrinsics.width), picture_height = std::max(1, cal.intrinsics.height);
    const gl::RgbImage grey_picture{picture_width, picture_height,
                                    std::vector<std::uint8_t>(std::size_t(picture_width) * std::size_t(picture_height) * 3, 128)};
    HdrImage grey_room(std::max(2, cfg.capture.map_width), std::max(1, cfg.capture.map_height));
    std::fill(grey_room.data().begin(), grey_room.data().end(), 0.5f);
    const auto warm_frame = [&] {  // as the frames draw it: the renderer's view, then the screen
        renderer.draw_scene();
        view.bind();
        renderer.composite();
        display->bind_frame();
        picture.draw_texture(view.texture(), true);
    };
    // AR's picture matched with the camera (docs/render.md, "Matching the camera"): noise when the
    // calibration has the sensor's, motion blur from the marker's motion.
    const bool match_noise = cfg.ar.match_camera && response.has_noise();
    const auto warm_backgrounds = [&] {
        renderer.set_background_environment(grey_room);
        warm_frame();
        renderer.set_background_image(grey_picture);
        warm_frame();
        if (cfg.ar.match_camera) {  // the composite's variants AR draws: with and without blur
            for (const glm::dvec2 blur : {glm::dvec2(0.0), glm::dvec2(8.0, 0.0)}) {
                renderer.set_camera_match({match_noise, 0, blur});
                warm_frame();
            }
            renderer.set_camera_match({});
        }
    };
    if (cfg.ar.shadows) {
        const render::ShadowLighting grey_lighting = render::shadow_lighting(grey);
        if (occluders.size() != 1) {  // a room's shadow will come with a bake (make_scene_shadow)
            // Both kinds of bake: one that holds the whole shadow (the frames draw it alone) and
            // one whose grid a low light's shadow outruns (the spheres' model beyond it).
            for (const bool open_beyond : {true, false}) {
                renderer.enable_shadows(grey_lighting, occluders);
                renderer.set_shadow_bake(render::unshadowed_bake(render::ShadowBakeOptions{}.resolution,
                                                                 render::model_bottom(mesh), open_beyond));
                warm_backgrounds();
            }
        }
        renderer.enable_shadows(grey_lighting, occluders);
    }
    warm_backgrounds();
    // Every material the button cycles to: each binds another set of maps (matte the irradiance
    // only, mirror the reflection only), which llvmpipe compiles a variant for (measured: the
    // first press in AR took 149 ms, the second 52 ms).
    for (std::size_t k = 1; k < materials.size(); ++k) {
        renderer.set_uniform_material(materials[k]);
        warm_frame();
    }
    if (materials.size() > 1) renderer.set_uniform_material(materials.front());
    // The first frames of AR: OpenCV's first board detection, corner refinement, pose and first
    // remap set up their tables and threads (measured: a 41 ms tracking step in the frame that
    // entered AR; a black picture, with no marker found, left the first real detection at 37 ms).
    // So the warm-up tracks the board itself, drawn at a plain pose filling most of the picture,
    // with a tracker of its own, so that the real one's history starts with the visitor's frames.
    {
        const tracking::Camera camera = tracking_camera(cal.intrinsics);
        const double distance_m = camera.fy * board.height_m() / (0.7 * picture_height);
        const cv::Mat board_gray = tracking::BoardRenderer(board, camera, /*supersample=*/1, /*texture_px_per_mm=*/2)
                                       .render(tracking::view_pose(distance_m, 25, 30, 0), {}, 1);
        cv::Mat board_rgb, gray;
        cv::cvtColor(board_gray, board_rgb, cv::COLOR_GRAY2RGB);
        tracking::Tracker warm_tracker(board, camera, glm::normalize(cal.sensor_from_camera * kGlFromCv));
        int found = 0;
        for (int k = 0; k < 2; ++k) {  // a first detection, then one from the predicted markers
            cv::cvtColor(lens.apply(board_rgb), gray, cv::COLOR_RGB2GRAY);
            found += warm_tracker.track(k * period_s, gray).detected ? 1 : 0;
        }
        if (found < 2) log("warm-up: the drawn board was found in " + std::to_string(found) + " of 2 pictures (the first AR frame may be slower)");
    }
    // The full-screen picture, into the screen's frame as the frames draw it (llvmpipe's variants
    // also depend on the target): the room's preview (PROCESSING), then the camera's (ATTRACT
    // before a first visit, CAPTURE). The preview's sides are powers of two, which llvmpipe
    // compiles another variant of the quad's shader for: the frame the scene arrived in drew it
    // first and took 19-52 ms, most of it in that draw call.
    display->bind_frame();
    for (const auto& [w, h] : {std::pair{kPreviewWidth, kPreviewHeight}, std::pair{picture_width, picture_height}}) {
        picture.upload(cv::Mat(h, w, CV_8UC3, cv::Scalar(0, 0, 0)));
        picture.draw();
    }
    glFinish();
    // The final maps' worker: its context and the GPU engine's programs are made now, on its own
    // thread at low priority, while the first frames (ATTRACT) run. Made in the frame that
    // received the scene, they stalled it (a PROCESSING frame of 92-108 ms).
    render::LiveMaps live_maps(display->context(), cfg.frame.budget_ms, /*wait_until_ready=*/false);
    bool final_maps_due = false;  // this visit's final maps are being made
    const WallClock::time_point wall_start = WallClock::now();

    const auto snapshot = [&](const std::string& why) {
        if (o.frames_dir.empty()) return;
        gl::RgbImage image = display->read_frame();
        char name[96];
        std::snprintf(name, sizeof name, "%05d_%s_%07.2fs_%s.png", frame_no, kiosk_state_name(flow.state()), t_s, why.c_str());
        gl::save_png(o.frames_dir / name, image);
    };
    // The lamp follows the state (screen_model.hpp, LampMode); it blinks from the start.
    LampMode lamp = LampMode::Blink;
    const auto lamp_for = [](KioskState s) {
        return s == KioskState::Attract ? LampMode::Blink : s == KioskState::Ar ? LampMode::On : LampMode::Off;
    };
    bool button_pressed = false, key_switch_on = false;
    const auto on_transition = [&](const std::optional<Transition>& tr) {
        if (!tr) return;
        if (lamp_for(tr->to) != lamp) source.set_lamp(lamp = lamp_for(tr->to));
        if (tr->to == KioskState::Capture) source.set_scanning(true);
        else if (tr->from == KioskState::Capture) source.set_scanning(false);
        states.push_back({{"name", kiosk_state_name(tr->to)}, {"t_s", tr->t_s}, {"reason", tr->reason}});
        // The live loop runs for months: summary.json keeps the last transitions (a replay's are
        // far fewer).
        if (states.size() > kMaxStatesKept) states.erase(states.begin());
        log(std::string("state ") + kiosk_state_name(tr->from) + " -> " + kiosk_state_name(tr->to) + " at " +
            std::to_string(tr->t_s) + " s: " + tr->reason);
        // The visit's big buffers (capture, maps) are freed by now: give the pages back, so that
        // the resident size does not creep up visit after visit (memory.hpp; a few ms, once a visit).
        if (tr->to == KioskState::Ar || tr->to == KioskState::Attract) return_freed_memory();
    };

    const bool replayed = source.replayed();
    DeviceWatch devices(o.devices, t_s);
    const std::string gl_renderer = reinterpret_cast<const char*>(glGetString(GL_RENDERER));
    std::vector<gl::InputEvent> window_keys;  // keys from a window display, handled next frame
    bool return_requested = false;          // the window was closed
    bool menu_has_keyboard = false;         // the overlay's maintenance menu is open
    const WallClock::time_point loop_start = WallClock::now();
    while (!(o.stop_requested && o.stop_requested())) {
        if (!replayed) t_s = seconds_since(loop_start);
        const std::int64_t now_ns = t0_ns + std::int64_t(std::llround(t_s * 1e9));
        if (source.ended(now_ns)) break;
        if (o.reload)
            if (std::optional<Config> fresh = o.reload()) {
                // What can change while running (docs/service.md): budgets, timeouts, capture settings.
                cfg.frame = fresh->frame;
                cfg.timeouts = fresh->timeouts;
                cfg.capture = fresh->capture;
                cfg.convolution = fresh->convolution;
                flow.set_timeouts(cfg.timeouts);
                scheduler.set_budget(cfg.frame.budget_ms, cfg.frame.hard_cap_ms);
                period_s = cfg.frame.budget_ms * 1e-3;
                log("configuration reloaded");
            }
        scheduler.begin_frame(flow.state());
        const KioskState state_at_start = flow.state();
        // Inputs that arrived by now: orientation samples, button and key events, camera frames.
        KioskPoll input = source.poll(now_ns);
        // The devices: frames out of order dropped, a silent camera restarted, a silent sensor
        // pausing the scan (docs/kiosk.md, "Devices that misbehave").
        std::erase_if(input.frames, [&](const capture::CameraFrame& f) { return !devices.accept_frame(f.t_ns); });
        if (o.observe_input) o.observe_input(input);
        {
            const DeviceWatch::Step watch = devices.update(t_s, input.frames.size(), input.orientations.size());
            for (const std::string& line : watch.log) log(line);
            if (watch.restart_camera) log(devices.camera_restarted(t_s, source.restart_camera()));
            const bool paused_before = flow.paused();
            flow.set_paused(t_s, devices.camera_lost() || devices.sensor_lost(),
                            devices.camera_lost() ? "message.camera_problem" : "message.sensor_problem");
            if (flow.paused() != paused_before) log(flow.paused() ? "scan paused: waiting for the devices" : "scan resumed");
        }
        // The window's keys go to the overlay (the menu) first; the visitor's button only when
        // the menu does not hold the keyboard.
        // A recorded session's keys ("key" down, "key_up") are what a window's keyboard gave.
        std::vector<gl::InputEvent> keys_now = std::move(window_keys);
        window_keys.clear();
        for (const capture::SessionEvent& e : input.events)
            if (e.source == "key" || e.source == "key_up")
                keys_now.push_back({e.source == "key" ? gl::InputEvent::Type::KeyDown : gl::InputEvent::Type::KeyUp, e.event});
        std::erase_if(input.events, [](const capture::SessionEvent& e) { return e.source == "key" || e.source == "key_up"; });
        if (!menu_has_keyboard)
            for (const gl::InputEvent& k : keys_now)
                if (k.type == gl::InputEvent::Type::KeyDown) input.events.push_back({now_ns, "key", k.key});
        for (const capture::SensorOrientation& s : input.orientations)
            // The tracker's clock is the camera's: sensor time minus the calibrated offset.
            tracker->add_orientation({kiosk_s(s.t_ns) - ar_time_offset_s, s.world_from_sensor});
        for (const capture::SessionEvent& e : input.events) {
            if (e.source == "button") button_pressed = e.event == "press";
            if (e.source == "key_switch" && key_switch_on != (e.event == "on")) {
                key_switch_on = e.event == "on";
                log(std::string("key switch ") + (key_switch_on ? "on" : "off"));
            }
            const bool press = (e.source == "button" && e.event == "press") ||
                               (e.source == "key" && (e.event == "space" || e.event == "Return"));
            if (!press) continue;
            on_transition(flow.button(t_s));
            if (flow.state() == KioskState::Capture && !capture_job) {
                capture::CaptureOptions co;
                source.configure_capture(co);
                co.out = scene_capture_path(o.maps_dir, source.replayed());  // committed with its coverage once read back
                co.compression = ExrCompression::None;  // the visitor waits for the write (docs/kiosk.md)
                co.width = cfg.capture.map_width;
                co.height = cfg.capture.map_height;
                co.threads = threads;
                co.guided.target_coverage = cfg.capture.target_coverage;
                co.guided.time_limit_s = cfg.capture.max_scan_s;
                capture_job = std::make_unique<CaptureJob>(co);
                // A new visit: its own scene, final maps and figures (the previous visitor's room
                // stays in `env` for ATTRACT until this one's is ready).
                scene_requested = false;
                scan_end_wall_s = lit_wall_s = final_maps_wall_s = -1;
                scan_end_reason.clear();
            }
        }
        bool pushed = false;
        for (capture::CameraFrame& f : input.frames) {
            // While the scan waits for the sensor its frames cannot be placed: not fed.
            if (flow.state() == KioskState::Capture && capture_job && !flow.paused()) {
                capture_job->push(f);
                pushed = true;
            }
            last_frame = std::move(f);
            last_rgb = last_frame.rgb;
            new_picture = true;
            background_stale = true;
        }
        scheduler.mark(FramePhase::Camera);
        // Deterministic: the capture has taken in this frame's pictures before the guide is asked.
        if (pushed && replayed) {
            capture_job->wait_for_frames();
            scheduler.exclude_since_mark();
        }

        // The flow. The scan's status is read once a frame: the flow and the screen use the same.
        CaptureLiveStatus live;
        if (flow.state() == KioskState::Capture && capture_job && capture_job->done()) {
            // The job ends before the scan only when it failed (a frame it cannot read, a
            // calibration that does not fit the camera): the visitor hears so now, not after
            // scanning on for nothing (a replay went on 45 s and then showed a map of 7 % of the room).
            try {
                capture_job->take();
                on_transition(flow.failure(t_s, "message.capture_failed", "the capture ended before the scan"));
            } catch (const std::exception& e) {
                on_transition(flow.failure(t_s, "message.capture_failed", e.what()));
            }
            // Gone now: failed in the pass that pressed the button, the job would outlive the
            // reset on leaving for ATTRACT below (this pass began in ATTRACT), and every later
            // visit would rethrow its error.
            capture_job.reset();
        }
        if (flow.state() == KioskState::Capture && capture_job) {
            live = capture_job->live();
            std::string why;
            if (live.has_step && live.step.state == capture::GuidedState::Complete) why = "scan complete";
            else if (live.has_step && live.step.state == capture::GuidedState::TimedOut) why = "scan time limit";
            else if (source.scan_end_ns() && now_ns >= *source.scan_end_ns()) why = "the recorded scan ended";
            if (!why.empty()) {
                capture_job->finish();
                scan_end_wall_s = seconds_since(wall_start);
                scan_end_reason = why;
                on_transition(flow.scan_finished(t_s, why));
            }
        }
        if (flow.state() == KioskState::Processing && capture_job && capture_job->done() && !scene_job.valid() &&
            !scene_requested) {
            scene_requested = true;
            try {
                capture_summary = capture_job->take();
                if (capture_summary->calibration_checked) {
                    alignment_text = capture::calibration_check_text(*capture_summary);
                    alignment_stale = capture_summary->calibration_stale;
                    log(std::string(alignment_stale ? "capture: warning: " : "capture: ") + "sensor-camera calibration " +
                        alignment_text);
                }
                // The map read back, its preview and the coarse maps on a worker: the frames go on.
                scene_job = std::async(std::launch::async, [maps_dir = o.maps_dir, replayed = source.replayed(), &log, &materials, threads] {
                    const WallClock::time_point t0 = WallClock::now();
                    NewScene scene;
                    scene.env = take_captured_scene(maps_dir, replayed, log);
                    const double read_s = seconds_since(t0);
                    scene.preview = preview_of(scene.env, kPreviewWidth, kPreviewHeight);
                    scene.maps = render::coarse_maps(scene.env, materials, threads);
                    char line[128];
                    std::snprintf(line, sizeof line, "scene: map read in %.3f s, preview and coarse maps in %.3f s", read_s,
                                  seconds_since(t0) - read_s);
                    log(line);
                    return scene;
                });
            } catch (const std::exception& e) {
                on_transition(flow.failure(t_s, "message.capture_failed", e.what()));
            }
        }
        if (flow.state() == KioskState::Processing && scene_job.valid() &&
            scene_job.wait_for(std::chrono::seconds(0)) == std::future_status::ready) {
            try {
                NewScene scene = scene_job.get();
                env = std::make_shared<const HdrImage>(std::move(scene.env));
                maps = std::make_shared<const render::ShadingMaps>(std::move(scene.maps));
                picture.upload(scene.preview);
                renderer.replace_maps(maps);
                // The AR view takes the calibration this map was made with (the file's again after
                // a scan that kept it); the tracker starts afresh with its mounting.
                const capture::CameraCalibration of_scan =
                    capture_summary ? capture::calibration_of_scan(cal, *capture_summary) : cal;
                if (of_scan.sensor_from_camera != ar_sensor_from_camera || of_scan.time_offset_s != ar_time_offset_s) {
                    ar_sensor_from_camera = of_scan.sensor_from_camera;
                    ar_time_offset_s = of_scan.time_offset_s;
                    tracker = make_tracker();
                    last_track.reset();
                    const bool scans = of_scan.sensor_from_camera != cal.sensor_from_camera ||
                                       of_scan.time_offset_s != cal.time_offset_s;
                    log(scans ? "capture: the AR view uses the scan's sensor-camera mounting and time offset"
                              : "capture: the AR view uses calibration.json's sensor-camera mounting and time offset");
                }
                // The final maps on the worker made at start-up (its context and programs ready).
                live_maps.start(env, materials);
                final_maps_due = true;
                have_scene = true;
                start_shadow(env);
                on_transition(flow.maps_ready(t_s));
            } catch (const std::exception& e) {
                on_transition(flow.failure(t_s, "message.processing_failed", e.what()));
            }
        }
        if (final_maps_due && live_maps.done()) {
            final_maps_due = false;
            if (std::optional<render::ShadingMaps> final_maps = live_maps.take()) {
                maps = std::make_shared<const render::ShadingMaps>(std::move(*final_maps));
                renderer.replace_maps(maps);
                final_maps_wall_s = seconds_since(wall_start);
                log("final maps after " + std::to_string(final_maps_wall_s - scan_end_wall_s) + " s from the scan's end");
            }
        }
        if (shadow_job.valid() && shadow_job.wait_for(std::chrono::seconds(0)) == std::future_status::ready) {
            try {
                SceneShadow shadow = shadow_job.get();
                if (!shadow_next) {  // else a newer room's shadow is due: this one is stale
                    renderer.enable_shadows(shadow.lighting, shadow.occluders);
                    if (shadow.bake) renderer.set_shadow_bake(*shadow.bake);
                    log("shadow: " + std::to_string(shadow.lighting.lights.size()) + " dominant light(s), " +
                        (shadow.bake ? std::to_string(shadow.bake->rays) + " rays" : std::string("one sphere")) + " in " +
                        std::to_string(shadow.seconds) + " s");
                }
            } catch (const std::exception& e) {
                log(std::string("shadow: not made: ") + e.what());  // the object is shown without it
            }
            if (shadow_next) {
                start_shadow(std::move(shadow_next));  // leaves shadow_next empty
            }
        }
        on_transition(flow.tick(t_s));
        if (flow.state() == KioskState::Attract && state_at_start != KioskState::Attract) {
            // A new visitor's scene starts from nothing; the old job (if any) finishes in the
            // background: kept aside, since dropping a running std::async future waits for it.
            capture_job.reset();
            if (scene_job.valid()) abandoned_scenes.push_back(std::move(scene_job));
        }
        std::erase_if(abandoned_scenes, [](const std::future<NewScene>& f) {
            return f.wait_for(std::chrono::seconds(0)) == std::future_status::ready;
        });

        scheduler.mark(FramePhase::Flow);

        // Tracking and the frame.
        ScreenModel model;
        model.state = flow.state();
        model.t_s = t_s;
        model.t_in_state_s = t_s - flow.entered_s();
        model.message = flow.message(t_s);
        model.degraded = display->degraded();
        model.shading_maps = have_scene ? maps.get() : nullptr;
        const std::int64_t frame_t_ns = last_frame.t_ns;
        const std::optional<glm::dquat> world_from_sensor =
            source.world_from_sensor(frame_t_ns + std::int64_t(std::llround(ar_time_offset_s * 1e9)));
        model.sensor_lost = devices.sensor_lost();
        model.camera_lost = devices.camera_lost();
        model.devices.camera_fps = devices.camera_fps();
        model.devices.sensor_rate_hz = devices.sensor_rate_hz();
        model.devices.exposure_s = last_frame.exposure_s;
        model.devices.gain = last_frame.total_gain();
        model.devices.camera_restarts = devices.counts().camera_restarts;
        model.devices.display_mode = display->describe();
        model.devices.gl_renderer = gl_renderer;
        model.devices.button_pressed = button_pressed;
        model.devices.key_switch_on = key_switch_on;
        model.devices.lamp = lamp;
        model.devices.alignment_check = alignment_text;
        model.devices.alignment_stale = alignment_stale;
        {
            const SourceHealth health = source.health();
            model.devices.sensor_health = devices.sensor_lost() ? "no orientation (" + health.sensor + ")" : health.sensor;
            model.devices.camera_error = health.camera_error;
        }
        const glm::dquat world_from_camera =
            world_from_sensor ? glm::normalize(*world_from_sensor * ar_sensor_from_camera) : glm::dquat(1, 0, 0, 0);
        if (flow.state() == KioskState::Ar && new_picture && !last_rgb.empty()) {
            cv::Mat gray;
            cv::cvtColor(last_rgb, gray, cv::COLOR_RGB2GRAY);
            pose_before.reset();
            if (last_track && last_track->has_pose) pose_before = last_track->pose;
            pose_before_t_ns = pose_t_ns;
            last_track = tracker->track(kiosk_s(frame_t_ns), gray);
            pose_t_ns = frame_t_ns;
            if (source.in_ar_phase(frame_t_ns)) {
                ++ar_frames;
                // The camera's world orientation the AR view lights the object by, against a
                // simulated session's truth: the sensor's error and the mounting's.
                if (world_from_sensor)
                    if (const auto truth = source.truth_camera(last_frame.sequence))
                        ar_camera_error_deg.push_back(angle_between(world_from_camera, *truth) * 180.0 / kPi);
                if (last_track->detected) {
                    ++ar_detected;
                    if (const auto truth = source.truth_board(last_frame.sequence))
                        ar_rotation_error_deg.push_back(
                            angle_between(last_track->detection.pose.rotation, truth->camera_from_board) * 180.0 / kPi);
                }
            }
        }
        scheduler.mark(FramePhase::Tracking);
        if (new_picture && !last_rgb.empty() && flow.state() != KioskState::Processing) picture.upload(last_rgb);
        // A frame without a new picture draws nothing new (8-9 ms of 33): the renderer uploads
        // one of the maps the button may switch to (8 MB for a mirror's).
        else renderer.upload_pending_map();
        new_picture = false;
        if (flow.material() != renderer_material) {
            renderer.set_uniform_material(materials[std::size_t(flow.material())]);
            renderer_material = flow.material();
        }
        if (flow.state() == KioskState::Ar) attract_background_set = false;  // the camera's picture from now on
        display->bind_frame();
        glClearColor(0, 0, 0, 1);
        glClear(GL_COLOR_BUFFER_BIT);
        if (flow.state() == KioskState::Ar && last_track && last_track->has_pose && last_track->visibility > 0 && !last_rgb.empty()) {
            renderer.set_camera(ar_camera(world_from_camera, last_track->pose, cal.intrinsics, placement));
            // The camera's picture, undistorted, goes to the renderer once per new picture (and
            // after ATTRACT showed the room instead).
            if (background_stale || !camera_background_set) {
                cv::Mat undistorted = lens.apply(last_rgb);
                if (!undistorted.isContinuous()) undistorted = undistorted.clone();
                background_upload.width = undistorted.cols;
                background_upload.height = undistorted.rows;
                background_upload.pixels.assign(undistorted.data, undistorted.data + undistorted.total() * 3);
                renderer.set_background_image(background_upload);
                background_stale = false;
                camera_background_set = true;
            }
            renderer.set_camera_response(response, {last_frame.exposure_s * 1e3, last_frame.total_gain()});
            render::Renderer::CameraMatch match;
            if (cfg.ar.match_camera) {
                match.noise = match_noise;
                match.frame = std::uint32_t(frame_no);
                // Between two pictures at most a quarter of a second apart: after a gap the motion is unknown.
                const double dt_s = double(pose_t_ns - pose_before_t_ns) * 1e-9;
                if (pose_before && dt_s > 0 && dt_s <= 0.25)
                    match.blur_px = ar_motion_blur_px(*pose_before, last_track->pose, dt_s, last_frame.exposure_s,
                                                      cal.intrinsics, view_height, placement);
            }
            renderer.set_camera_match(match);
            renderer.draw_scene();
            view.bind();
            renderer.composite();
            display->bind_frame();
            picture.draw_texture(view.texture(), true);
        } else if (flow.state() == KioskState::Attract && have_scene) {
            // The last visitor's object, slowly orbiting in the room it was lit by.
            renderer.set_camera(orbit_camera(t_s * 12.0));
            renderer.set_camera_match({});  // the room's own picture: nothing of the camera to match
            if (!attract_background_set) {  // 6 MB of texture: once per visit of ATTRACT
                renderer.set_background_environment(env ? *env : *last_scene);
                attract_background_set = true;
                camera_background_set = false;
            }
            renderer.draw_scene();
            view.bind();
            renderer.composite();
            display->bind_frame();
            picture.draw_texture(view.texture(), true);
        } else if (!picture.empty()) {
            picture.draw();
        }
        scheduler.mark(FramePhase::Render);

        // The screen's model and the overlay.
        if (flow.state() == KioskState::Capture && capture_job) {
            if (live.has_step) {
                // The target in the camera frame, OpenCV axes (the screens draw the arrow from it).
                const glm::dvec3 c = kGlFromCv * (glm::conjugate(live.world_from_camera) * live.step.next_target);
                model.capture.target_x = c.x;
                model.capture.target_y = c.y;
                model.capture.target_z = c.z;
                model.capture.turn_deg = live.step.turn_to_target_deg;
                model.capture.on_target = live.step.turn_to_target_deg < 10;
                model.capture.too_fast = live.step.too_fast;
                model.capture.exposure = live.step.exposure == capture::ExposureStatus::TooBright ? "too_bright"
                                         : live.step.exposure == capture::ExposureStatus::TooDark ? "too_dark"
                                                                                                 : "ok";
                if (source.exposure_state() == "bracketing") model.capture.exposure = "bracketing";
                model.capture.progress = live.step.progress;
                model.capture.time_left_s = std::max(0.0, cfg.capture.max_scan_s - live.step.elapsed_s);
                model.capture.minimap_width = live.minimap_width;
                model.capture.minimap_height = live.minimap_height;
                model.capture.minimap = live.minimap;
                const glm::dvec3 looking = live.world_from_camera * glm::dvec3(0, 0, -1);
                model.capture.view_x = looking.x;
                model.capture.view_y = looking.y;
                model.capture.view_z = looking.z;
                model.capture.next_x = live.step.next_target.x;
                model.capture.next_y = live.step.next_target.y;
                model.capture.next_z = live.step.next_target.z;
            }
        } else if (flow.state() == KioskState::Processing) {
            const double p = capture_job ? capture_job->finishing_progress() : 1.0;
            const bool convolving = scene_job.valid();
            model.processing.progress = convolving ? 0.9 : 0.8 * p;
            model.processing.step = convolving ? "processing.convolving" : "processing.adjusting";
            model.processing.time_left_s = convolving ? 0.5 : std::max(0.5, 2.0 * (1 - p));
        } else if (flow.state() == KioskState::Ar) {
            model.ar.material = material_key(cfg.ar.materials[std::size_t(flow.material())]);
            model.ar.tracked = last_track && last_track->detected;
            model.ar.bridged = last_track && last_track->from_sensor;
            model.ar.visibility = last_track ? last_track->visibility : 0;
        }
        if (overlay) menu_has_keyboard = overlay(model, period_s, keys_now);
        scheduler.mark(FramePhase::Overlay);

        const bool changed = flow.state() != state_at_start || frame_no == 0;
        const bool periodic = o.snapshot_every_s > 0 && t_s - last_snapshot_s >= o.snapshot_every_s;
        if (changed || periodic) {
            scheduler.mark(FramePhase::Present);
            snapshot(changed ? "state" : "every");
            scheduler.exclude_since_mark();  // the PNG is the replay's, not the appliance's
            last_snapshot_s = t_s;
        }
        display->present();
        scheduler.mark(FramePhase::Present);
        // A GPU reset loses every texture and program: no way on but a new process (systemd
        // restarts it), so one clear line and a non-zero exit.
        if (glGetGraphicsResetStatus() != GL_NO_ERROR || (o.fault_gl_lost_at_s && t_s >= *o.fault_gl_lost_at_s))
            throw RuntimeError("the GL context was lost (GPU reset) on " + display->describe() + "; the kiosk must restart");
        if (o.after_present) o.after_present(flow.state(), frame_no);
        for (const gl::InputEvent& e : display->poll_events()) {
            if (e.type == gl::InputEvent::Type::Quit) return_requested = true;
            else window_keys.push_back(e);  // key down and up (the menu's chord tracks held modifiers)
        }
        if (flow.state() == KioskState::Ar && lit_wall_s < 0 && scan_end_wall_s >= 0) lit_wall_s = seconds_since(wall_start);
        if (first_frame_s < 0) {
            first_frame_s = process_age_s();
            char line[96];
            std::snprintf(line, sizeof line, "first frame on screen %.2f s after the process started", first_frame_s);
            log(line);
        }
        const double frame_ms = scheduler.end_frame();
        live_maps.after_frame(frame_ms);
        ++frame_no;

        // The clock: the replay's own, at wall pace while the scan's map is finished (or always
        // with --realtime).
        const bool wall_paced = !replayed || flow.state() == KioskState::Processing;
        if (wall_paced) {
            const double rest_ms = cfg.frame.budget_ms - frame_ms;
            if (rest_ms > 0) std::this_thread::sleep_for(std::chrono::duration<double, std::milli>(rest_ms));
        }
        if (replayed) t_s += period_s;
        if (o.progress) o.progress(t_s, 0);
        if (return_requested) break;
    }
    if (final_maps_due) {
        live_maps.finish();  // the replay ended first: the maps are still made, for the figures
        if (std::optional<render::ShadingMaps> final_maps = live_maps.take())
            maps = std::make_shared<const render::ShadingMaps>(std::move(*final_maps));
        final_maps_wall_s = seconds_since(wall_start);
    }
    capture_job.reset();

    // The figures.
    json summary;
    summary["source"] = source.describe();
    summary["display"] = display->describe();
    summary["states"] = states;
    json by_state = json::object();
    for (const auto& [state, times] : scheduler.by_state()) by_state[kiosk_state_name(state)] = frame_times_json(times);
    json frame_ms = frame_times_json(scheduler.all());
    frame_ms["budget"] = cfg.frame.budget_ms;
    frame_ms["hard_cap"] = cfg.frame.hard_cap_ms;
    frame_ms["over_hard_cap"] = scheduler.over_cap();
    frame_ms["by_state"] = by_state;
    const auto means = scheduler.phase_means();
    json phases = json::object();
    for (int k = 0; k < int(FramePhase::Count); ++k) phases[frame_phase_name(FramePhase(k))] = means[std::size_t(k)];
    frame_ms["phase_mean"] = phases;
    summary["frame_ms"] = frame_ms;
    summary["startup_to_first_frame_s"] = first_frame_s;
    const DeviceWatch::Counts& device_counts = devices.counts();
    summary["devices"] = {{"camera_losses", device_counts.camera_losses},
                          {"camera_restarts", device_counts.camera_restarts},
                          {"camera_restart_failures", device_counts.camera_restart_failures},
                          {"camera_lost_s", device_counts.camera_lost_s},
                          {"sensor_losses", device_counts.sensor_losses},
                          {"sensor_lost_s", device_counts.sensor_lost_s},
                          {"frames_out_of_order", device_counts.frames_out_of_order},
                          {"scan_paused_s", flow.paused_total_s()}};
    summary["scan_end_reason"] = scan_end_reason.empty() ? json() : json(scan_end_reason);
    summary["scan_end_to_lit_s"] = lit_wall_s >= 0 ? json(lit_wall_s - scan_end_wall_s) : json();
    summary["scan_end_to_final_maps_s"] = final_maps_wall_s >= 0 && scan_end_wall_s >= 0 ? json(final_maps_wall_s - scan_end_wall_s) : json();
    summary["coverage"] = capture_summary ? json(capture_summary->coverage.covered_fraction) : json();
    summary["tracking_detection_rate"] = ar_frames > 0 ? json(double(ar_detected) / ar_frames) : json();
    summary["tracking_frames"] = ar_frames;
    if (!ar_camera_error_deg.empty()) {
        std::sort(ar_camera_error_deg.begin(), ar_camera_error_deg.end());
        summary["ar_camera_orientation_error_deg"] = {{"median", ar_camera_error_deg[ar_camera_error_deg.size() / 2]},
                                                      {"max", ar_camera_error_deg.back()}};
    }
    if (!ar_rotation_error_deg.empty()) {
        std::sort(ar_rotation_error_deg.begin(), ar_rotation_error_deg.end());
        summary["tracking_rotation_error_deg"] = {{"median", ar_rotation_error_deg[ar_rotation_error_deg.size() / 2]},
                                                  {"max", ar_rotation_error_deg.back()}};
    }
    if (capture_summary) {
        summary["capture"] = {{"frames_used", capture_summary->frames_used},
                              {"last_frame_to_map_s", capture_summary->last_frame_to_map_seconds},
                              {"last_frame_to_saved_s", capture_summary->last_frame_to_saved_seconds},
                              {"calibration_turn_deg", capture_summary->calibration_checked
                                                           ? json(capture_summary->calibration_turn_deg)
                                                           : json()},
                              {"calibration_time_offset_ms", capture_summary->calibration_checked
                                                                 ? json(capture_summary->calibration_time_offset_ms)
                                                                 : json()},
                              {"calibration_stale", capture_summary->calibration_checked
                                                        ? json(capture_summary->calibration_stale)
                                                        : json()},
                              {"calibration_refined", capture_summary->calibration_checked
                                                          ? json(capture_summary->calibration_refined)
                                                          : json()},
                              {"calibration_refined_during_scan_s",
                               capture_summary->calibration_refined_during_scan_s
                                   ? json(*capture_summary->calibration_refined_during_scan_s)
                                   : json()},
                              {"guided_complete_after_s", capture_summary->guided_complete_after_s
                                                              ? json(*capture_summary->guided_complete_after_s)
                                                              : json()}};
    }
    if (!o.frames_dir.empty())
        summary["frames_written"] = std::distance(fs::directory_iterator(o.frames_dir), fs::directory_iterator{});
    summary["wall_s"] = seconds_since(process_start);
    if (!o.frame_log.empty()) {
        std::string csv = "frame,state,ms";
        for (int k = 0; k < int(FramePhase::Count); ++k) csv += std::string(",") + frame_phase_name(FramePhase(k)) + "_ms";
        csv += "\n";
        long long n = 0;
        for (const FrameScheduler::FrameRecord& r : scheduler.records()) {
            char line[64];
            std::snprintf(line, sizeof line, "%lld,%s,%.3f", n++, kiosk_state_name(r.state), r.ms);
            csv += line;
            for (double ms : r.phase_ms) {
                std::snprintf(line, sizeof line, ",%.3f", ms);
                csv += line;
            }
            csv += "\n";
        }
        write_text_atomically(o.frame_log, csv);
    }
    KioskResult result;
    result.summary = std::move(summary);
    result.capture = std::move(capture_summary);
    if (env) result.env = *env;
    return result;
}

}  // namespace glint::ui
