// `glint render`: one object lit by an environment map's irradiance and reflection maps, on a
// display (headless by default), with its AOVs and frame times (docs/render.md).
//
// It lives in `glint`, not glint-vision: it needs GL, the displays, the convolution and core, and
// no OpenCV or libcamera (docs/architecture.md, "Commands: two executables").
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <nlohmann/json.hpp>
#include <utility>
#include <vector>

#include "appliance/app/cli_util.hpp"
#include "appliance/app/commands.hpp"
#include "appliance/core/atomic_file.hpp"
#include "appliance/core/errors.hpp"
#include "appliance/core/strict_number.hpp"
#include "appliance/core/progress.hpp"
#include "appliance/core/exr_io.hpp"
#include "appliance/gl/display.hpp"
#include "appliance/render/ao_bake.hpp"
#include "appliance/render/ao_file.hpp"
#include "appliance/render/camera_response.hpp"
#include "appliance/render/live_maps.hpp"
#include "appliance/render/maps.hpp"
#include "appliance/render/material.hpp"
#include "appliance/render/mesh.hpp"
#include "appliance/render/renderer.hpp"
#include "appliance/render/teapot.hpp"
#include "appliance/render/shadow.hpp"
#include "appliance/render/shadow_bake.hpp"

namespace glint::app {
namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

struct RenderArgs {
    std::string env;
    std::string maps;
    std::string model = "sphere";
    std::string material = "matte";
    bool material_given = false;  // --material on the command line (else a glTF's own material)
    std::string background = "env";
    std::string size = "1280x720";
    std::string out;
    std::string aov;
    bool no_ao = false;
    int frames = 1;
    std::string stats;
    std::string display = "headless";
    double key = 0.18;
    int threads = 0;
    std::string shadows = "auto";       // on, off; auto = on over env or an image, off over black
    std::vector<std::string> proxies;   // OBJ files, world coordinates
    std::optional<double> table_height; // default: the model's lowest point
    int msaa = 4;                       // samples a pixel of the frame (1: none)
    std::string frame_targets = "auto";  // auto | float | half (render::FrameTargets)
    std::string camera;                 // calibration.json: the camera's response instead of Reinhard
    double exposure_ms = 10;
    double gain = 1;
    bool exposure_given = false, gain_given = false;
    bool camera_noise = false;          // the sensor's noise on virtual pixels (needs --camera with "noise")
    std::string motion_blur;            // "DX,DY": the object's motion during the exposure, pixels
    bool live_maps = false;             // final maps by the GPU engine in the frames' leftover time
    double frame_budget_ms = 1000.0 / 30.0;
    bool budget_given = false;
};

// The model's baked ambient occlusion (docs/render.md, "Ambient occlusion"): MODEL.ao beside a
// model file when it matches (a stale or unreadable one is reported and ignored); the built-in
// teapot is baked here, at each run (0.35 s at level 16 on two loaded cores); the
// sphere has none (ao = 1: nothing of a convex object occludes itself).
void load_ambient_occlusion(const std::string& model, render::Mesh& mesh) {
    if (model == "sphere") return;
    if (!render::model_is_file(model)) {
        const auto t0 = Clock::now();
        render::AoBakeOptions options;
        options.progress = progress_callback("baking the teapot's ambient occlusion (vertices)");
        // A teapot finer than the default is baked at the default level and the ao resampled in
        // each patch's (u, v): ao varies slowly over the surface, and teapot:40 would take 10x as
        // long to bake (docs/render.md measures the difference).
        const int level = model == "teapot" ? render::kTeapotDefaultLevel : std::stoi(model.substr(7));
        const int bake_level = std::min(level, render::kTeapotDefaultLevel);
        if (bake_level == level) {
            mesh.ao = render::bake_ambient_occlusion(mesh, options);
        } else {
            render::Mesh coarse = render::make_teapot(bake_level);
            render::normalise_to_unit_sphere(coarse);
            mesh.ao = render::resample_teapot_field(render::bake_ambient_occlusion(coarse, options), bake_level, level);
        }
        std::printf("ambient occlusion: baked for %s at level %d (%d rays, max distance %.2g radius) in %.2f s\n",
                    model.c_str(), bake_level, options.rays, options.max_distance_relative,
                    std::chrono::duration<double>(Clock::now() - t0).count());
        return;
    }
    render::AoLookup lookup = render::find_ao_for(model, mesh.positions.size());
    if (lookup.found && !lookup.used) std::fprintf(stderr, "glint: warning: ambient occlusion ignored, %s\n", lookup.status.c_str());
    std::printf("ambient occlusion: %s\n", lookup.used ? lookup.status.c_str() : "none (ao = 1)");
    mesh.ao = std::move(lookup.ao);
}

// The material of each part of the model (glTF primitives, OBJ usemtl groups): --material for
// all when given, else each part's own (docs/render.md, "Several materials"), --material's
// default for an OBJ group whose MTL material is missing. Says what it did.
std::vector<render::Material> materials_of(const render::Mesh& mesh, const render::Material& chosen, bool given) {
    for (const render::GltfMaterial& g : mesh.materials)
        if (g.textured && !given)
            std::fprintf(stderr, "glint: warning: %s: material '%s' names textures, which are not read (its factors are used)\n",
                         mesh.source.c_str(), g.name.c_str());
    if (!given)
        for (const render::ObjMaterial& o : mesh.obj_materials)
            if (!o.defined)
                std::fprintf(stderr, "glint: warning: %s: material '%s' is defined by no mtllib file; its faces use %s\n",
                             mesh.source.c_str(), o.name.empty() ? "(before any usemtl)" : o.name.c_str(), chosen.spec.c_str());
    return render::part_materials(mesh, chosen, given);
}

// Nearest-rank percentile of sorted values.
double percentile(const std::vector<double>& sorted, double p) {
    if (sorted.empty()) return 0;
    const std::size_t rank = std::size_t(std::ceil(p / 100.0 * double(sorted.size())));
    return sorted[std::min(sorted.size() - 1, rank == 0 ? 0 : rank - 1)];
}

double median(const std::vector<double>& sorted) {
    if (sorted.empty()) return 0;
    const std::size_t n = sorted.size();
    return n % 2 ? sorted[n / 2] : 0.5 * (sorted[n / 2 - 1] + sorted[n / 2]);
}

int run_render(const RenderArgs& args) {
    // Everything the user typed is checked before any work.
    render::Material material = render::parse_material(args.material, "--material");
    const convolution::Size size = parse_size(args.size, "--size");
    if (args.frames < 1) throw InputError("--frames: must be at least 1");
    if (!(args.key > 0 && args.key < 1)) throw InputError("--key: must be in (0, 1)");
    std::optional<gl::RgbImage> background_image;
    if (args.background != "env" && args.background != "black") {
        if (fs::path(args.background).extension() != ".png")
            throw InputError("--background " + args.background + ": want env, black or a .png image");
        background_image = gl::load_png(args.background);
    }
    if (args.live_maps && !args.maps.empty()) throw InputError("--live-maps: not with --maps (the maps are made while the frames run)");
    if (args.budget_given && !args.live_maps) throw InputError("--frame-budget-ms: needs --live-maps");
    if (!(args.frame_budget_ms > 0 && std::isfinite(args.frame_budget_ms))) throw InputError("--frame-budget-ms: must be positive");
    std::optional<render::CameraResponse> camera;
    if (!args.camera.empty()) camera = render::load_camera_response(args.camera, "--camera");
    if (!camera && (args.exposure_given || args.gain_given))
        throw InputError(std::string(args.exposure_given ? "--exposure-ms" : "--gain") + ": needs --camera CAL.json");
    if (!(args.exposure_ms > 0 && std::isfinite(args.exposure_ms))) throw InputError("--exposure-ms: must be positive");
    // Checked before the convolution: a mistyped flag should not cost its seconds.
    render::Renderer::CameraMatch match;
    if (!args.motion_blur.empty()) {
        const std::size_t comma = args.motion_blur.find(',');
        if (comma == std::string::npos)
            throw InputError("--motion-blur: \"" + args.motion_blur + "\" is not DX,DY (pixels, e.g. 12,-3)");
        const std::string_view blur = args.motion_blur;
        match.blur_px = {parse_double(blur.substr(0, comma), "--motion-blur"),
                         parse_double(blur.substr(comma + 1), "--motion-blur")};
    }
    if (args.camera_noise && !camera) throw InputError("--camera-noise: needs --camera CAL.json (with \"noise\")");
    if (args.camera_noise && !camera->has_noise())
        throw InputError("--camera-noise: " + camera->source +
                         " has no \"noise\" (full_well_electrons, read_noise); add the sensor's from its datasheet");
    match.noise = args.camera_noise;
    if (!(args.gain > 0 && std::isfinite(args.gain))) throw InputError("--gain: must be positive");
    render::Mesh mesh = render::load_model(args.model);
    if (!args.no_ao) load_ambient_occlusion(args.model, mesh);
    const std::vector<render::Material> part_materials = materials_of(mesh, material, args.material_given);
    {
        std::vector<render::Material> distinct;
        for (const render::Material& m : part_materials)
            if (std::none_of(distinct.begin(), distinct.end(), [&](const render::Material& d) { return render::same_shading(d, m); }))
                distinct.push_back(m);
        for (std::size_t k = 0; k < distinct.size(); ++k)
            if (distinct.size() == 1) std::printf("material: %s\n", distinct[k].spec.c_str());
            else std::printf("material %zu: %s\n", k, distinct[k].spec.c_str());
    }
    std::vector<render::Mesh> proxies;
    for (const std::string& file : args.proxies) {
        if (fs::path(file).extension() != ".obj") throw InputError("--proxy " + file + ": want an .obj file");
        try {
            proxies.push_back(render::load_obj(file));  // world coordinates: not normalised
        } catch (const InputError& e) {
            throw InputError(std::string("--proxy: ") + e.what());
        }
    }
    const bool shadows = args.shadows == "auto" ? args.background != "black" : args.shadows == "on";
    const double table_height = args.table_height.value_or(render::model_bottom(mesh));
    // Files are written after the frames: a place they cannot go is bad input, found first.
    for (const auto& [flag, file] : {std::pair{"--out", args.out}, std::pair{"--stats", args.stats}}) {
        if (file.empty()) continue;
        const fs::path parent = fs::absolute(fs::path(file)).parent_path();
        if (!fs::is_directory(parent))
            throw InputError(std::string(flag) + " " + file + ": the directory " + parent.string() + " does not exist");
    }
    if (!args.aov.empty() && fs::exists(args.aov) && !fs::is_directory(args.aov))
        throw InputError("--aov " + args.aov + ": exists and is not a directory");

    // The display first: one that cannot open fails before any convolution.
    gl::DisplayConfig config;
    config.kind = args.display;
    config.width = size.width;
    config.height = size.height;
    std::vector<gl::DisplayAttempt> attempts;
    std::unique_ptr<gl::Display> display = gl::open_display(config, &attempts);
    for (const auto& a : attempts)
        if (!a.ok) std::fprintf(stderr, "glint: display %s: %s\n", gl::display_kind_name(a.kind), a.detail.c_str());
    std::printf("display: %s%s\n", display->describe().c_str(), display->degraded() ? " (degraded: fell back)" : "");

    const auto t_maps = Clock::now();
    render::ShadingMaps maps;
    if (!args.maps.empty()) maps = render::load_maps(args.maps, part_materials);  // before the environment: a missing map is bad input, found first
    LoadedExr env = load_exr(args.env);
    warn_about_environment(args.env, env);

    if (args.live_maps) {
        maps = render::coarse_maps(env.image, part_materials, args.threads);  // the final ones come during the frames
    } else if (args.maps.empty()) {
        convolution::Options options;
        options.tolerance = 0.01;
        options.threads = args.threads;
        options.fine_tiles = true;  // as glint convolve: the shader reads the tiles
        maps = render::convolve_maps(env.image, part_materials, options);
    }
    const double maps_s = std::chrono::duration<double>(Clock::now() - t_maps).count();
    if (maps.irradiance) std::printf("irradiance: %s\n", maps.irradiance_from.c_str());
    for (const render::ReflectionMap& r : maps.reflections)
        std::printf("reflection %s: %s\n", r.request.label.c_str(), r.from.c_str());


    const render::FrameTargets targets = args.frame_targets == "half"    ? render::FrameTargets::Half
                                         : args.frame_targets == "float" ? render::FrameTargets::Float
                                                                         : render::FrameTargets::Auto;
    render::Renderer renderer(mesh, part_materials, maps, display->width(), display->height(), render::Camera{}, args.msaa,
                              targets);
    std::printf("msaa: %dx\n", args.msaa);
    renderer.set_ambient_occlusion(!args.no_ao);
    if (args.background == "env") renderer.set_background_environment(env.image);
    else if (background_image) renderer.set_background_image(*background_image);
    else renderer.set_background_black();
    for (const render::Mesh& proxy : proxies) renderer.add_proxy(proxy);
    if (shadows || args.table_height || !proxies.empty()) renderer.set_table(table_height);
    if (shadows) {
        const render::ShadowLighting lighting = render::shadow_lighting(env.image);
        const std::vector<render::OccluderSphere> occluders = render::occluder_spheres(mesh);
        std::printf("table: y = %.4g; shadow: %zu dominant light(s), %zu occluder sphere(s)\n", table_height,
                    lighting.lights.size(), occluders.size());
        double table_irradiance = lighting.ambient_irradiance.y;  // green: close to luminance, no weights needed
        for (const auto& e : lighting.light_irradiance) table_irradiance += e.y;
        for (std::size_t i = 0; i < lighting.lights.size(); ++i) {
            const render::DominantLight& l = lighting.lights[i];
            std::printf("  light %zu: direction (%.4f, %.4f, %.4f), %.4g sr (radius %.3g deg), %.3g of the table's "
                        "irradiance (G)\n",
                        i, l.direction.x, l.direction.y, l.direction.z, l.solid_angle,
                        l.angular_radius() * 180.0 / 3.141592653589793,
                        lighting.light_irradiance[i].y / std::max(1e-30, table_irradiance));
        }
        renderer.enable_shadows(lighting, occluders);
        // Anything but the sphere model (one occluder sphere that is the object itself): the shadow
        // baked against the real mesh near the object (docs/render.md, "Baked shadows").
        if (occluders.size() != 1) {
            const render::ShadowBake bake = render::bake_table_shadow(mesh, lighting, table_height);
            renderer.set_shadow_bake(bake);
            std::printf("shadow: baked against the mesh on a %dx%d grid (spacing %.3g), %lld rays in %.2f s\n",
                        bake.resolution, bake.resolution, bake.spacing, bake.rays, bake.seconds);
        }
    }

    if (camera) {
        const render::CameraExposure exposure{args.exposure_ms, args.gain};
        renderer.set_camera_response(*camera, exposure);
        std::printf("camera: %s (%s response, sensitivity %.4g), exposure %.4g ms, gain %.4g: radiance 1 -> code %.2f\n",
                    camera->source.c_str(), camera->parametric() ? "parametric" : "tabulated", camera->sensitivity,
                    args.exposure_ms, args.gain, camera->code(exposure.scale(*camera)));
    }
    renderer.set_camera_match(match);
    if (match.noise || glm::length(match.blur_px) > 0)
        std::printf("matching the camera:%s%s\n", match.noise ? " the sensor's noise (a new pattern each frame)" : "",
                    glm::length(match.blur_px) > 0 ? (" motion blur of (" + std::to_string(match.blur_px.x) + ", " +
                                                      std::to_string(match.blur_px.y) + ") pixels").c_str()
                                                   : "");
    // The scene is still, so the tone map is metered once, before the timed frames.
    const render::ToneMap& tone = renderer.meter(args.key);
    if (!camera) std::printf("tone map: Reinhard, key %.3g, log-average luminance %.6g, white %.6g (scaled), %lld pixels metered\n",
                tone.key, tone.log_average, tone.white, tone.pixels);

    // --live-maps: the final maps' job starts now; each frame grants it what is left of the budget.
    std::unique_ptr<render::LiveMaps> live;
    int final_maps_frame = -1;  // the first frame drawn with the final maps
    const auto adopt_final_maps = [&](int frame) {
        if (std::optional<render::ShadingMaps> final_maps = live->take()) {
            renderer.replace_maps(*final_maps);
            final_maps_frame = frame;
            std::printf("live maps: final maps after %.2f s, from frame %d on (%lld tiles, %.1f ms GPU)\n", live->seconds(),
                        frame, live->tiles().tiles, live->tiles().gpu_ms);
            if (final_maps->irradiance) std::printf("irradiance: %s\n", final_maps->irradiance_from.c_str());
            for (const render::ReflectionMap& r : final_maps->reflections)
                std::printf("reflection %s: %s\n", r.request.label.c_str(), r.from.c_str());
        }
    };
    if (args.live_maps) {
        live = std::make_unique<render::LiveMaps>(display->context(), env.image, part_materials, args.frame_budget_ms);
        std::printf("live maps: coarse maps now, the final ones on the GPU in each frame's time left of %.1f ms\n",
                    args.frame_budget_ms);
    }
    std::vector<double> frame_ms, slice_ms;
    for (int f = 0; f < args.frames; ++f) {
        if (live && live->done() && final_maps_frame < 0) adopt_final_maps(f);
        const auto t0 = Clock::now();
        renderer.draw_scene();
        display->bind_frame();
        match.frame = std::uint32_t(f);
        renderer.set_camera_match(match);
        renderer.composite();
        display->present();
        frame_ms.push_back(std::chrono::duration<double, std::milli>(Clock::now() - t0).count());
        if (live) slice_ms.push_back(live->after_frame(frame_ms.back()));
        for (const auto& e : display->poll_events())
            if (e.type == gl::InputEvent::Type::Quit || (e.type == gl::InputEvent::Type::KeyDown && e.key == "Escape"))
                f = args.frames;
    }

    // The files show the final maps: a job not done within the frames gets the GPU until it is.
    if (live && final_maps_frame < 0 && (!args.out.empty() || !args.aov.empty())) {
        live->finish();
        adopt_final_maps(args.frames);
    }
    // One more frame, untimed, for the files: the read-backs are not part of a frame's cost.
    if (!args.out.empty() || !args.aov.empty()) {
        renderer.draw_scene();
        display->bind_frame();
        renderer.composite();
        if (!args.out.empty()) gl::save_png(args.out, display->read_frame());
        display->present();
        if (!args.aov.empty()) render::save_aovs(args.aov, renderer.read_aovs());
    }

    std::vector<double> sorted = frame_ms;
    std::sort(sorted.begin(), sorted.end());
    const double med = median(sorted), p99 = percentile(sorted, 99), max = sorted.back();
    std::printf("%zu frames at %dx%d: median %.3f ms, p99 %.3f ms, max %.3f ms (%zu triangles)\n", frame_ms.size(),
                display->width(), display->height(), med, p99, max, mesh.triangle_count());
    if (!args.stats.empty()) {
        nlohmann::json s;
        s["frames"] = frame_ms.size();
        s["width"] = display->width();
        s["height"] = display->height();
        s["display"] = display->describe();
        s["degraded"] = display->degraded();
        s["renderer"] = display->context().caps().renderer;
        s["model"] = mesh.source;
        s["triangles"] = mesh.triangle_count();
        s["material"] = part_materials.front().spec;
        s["materials"] = nlohmann::json::array();
        for (const render::Material& m : part_materials) s["materials"].push_back(m.spec);
        s["draws"] = renderer.draws();
        s["shadows"] = shadows;
        s["msaa"] = args.msaa;
        s["frame_targets"] = renderer.frame_format();
        if (live)
            s["live_maps"] = {{"frame_budget_ms", args.frame_budget_ms},
                              {"final_from_frame", final_maps_frame >= 0 ? nlohmann::json(final_maps_frame) : nlohmann::json()},
                              {"job_seconds", live->done() ? nlohmann::json(live->seconds()) : nlohmann::json()},
                              {"tiles", live->tiles().tiles}, {"tile_gpu_ms", live->tiles().gpu_ms},
                              {"slice_ms_all", slice_ms}};
        if (camera) s["camera"] = {{"calibration", args.camera}, {"exposure_ms", args.exposure_ms}, {"gain", args.gain}};
        s["proxies"] = args.proxies.size();
        s["maps_seconds"] = maps_s;
        s["irradiance"] = maps.irradiance ? nlohmann::json(maps.irradiance_from) : nlohmann::json();
        s["reflection"] = maps.reflections.empty() ? nlohmann::json() : nlohmann::json(maps.reflections.front().from);
        s["reflections"] = nlohmann::json::object();
        for (const render::ReflectionMap& r : maps.reflections) s["reflections"][r.request.label] = r.from;
        s["tone_map"] = {{"operator", "reinhard"}, {"key", tone.key}, {"log_average", tone.log_average},
                         {"white_scaled", tone.white}, {"delta", tone.delta}};
        s["frame_ms"] = {{"median", med}, {"p99", p99}, {"max", max}};
        s["frame_ms_all"] = frame_ms;
        write_text_atomically(args.stats, s.dump(2) + "\n");
    }
    if (!args.out.empty()) std::printf("wrote %s\n", args.out.c_str());
    if (!args.aov.empty())
        std::printf("wrote radiance.exr, normal.exr, reflect.exr%s to %s\n", shadows ? ", shadow.exr" : "",
                    args.aov.c_str());
    return 0;
}

}  // namespace

Command add_render_command(CLI::App& app) {
    auto args = std::make_shared<RenderArgs>();
    CLI::App* cmd = app.add_subcommand("render", std::string(command_summary("render").summary));
    cmd->add_option("--env", args->env, "Equirectangular HDR environment map (OpenEXR)")->required();
    cmd->add_option("--maps", args->maps,
                    "Directory written by glint convolve (report.json names the maps); without it the maps the "
                    "material needs are convolved first (CPU, tolerance 1 %)");
    cmd->add_option("--model", args->model, "sphere, teapot (Newell's, 16 256 triangles), teapot:LEVEL (64 L^2 - 8 L triangles; 40 gives 102 080), or an .obj, .gltf or .glb file")->capture_default_str();
    CLI::Option* material_option = cmd->add_option("--material", args->material,
                    "matte, glossy:N, mirror or 'kd=R,G,B;ks=R,G,B;n=N' (Phong: kd E_d(N) ao + ks E_s^n(R)); a glTF model "
                    "without it uses its own metallic-roughness material mapped to Phong")
        ->capture_default_str();
    cmd->add_option("--background", args->background, "env (the environment through the camera), black or IMAGE.png")
        ->capture_default_str();
    cmd->add_option("--size", args->size, "Frame size WxH (headless and window; kms uses its mode)")
        ->check(size_validator())
        ->capture_default_str();
    cmd->add_option("--out", args->out, "Write the displayed frame as PNG");
    cmd->add_option("--aov", args->aov, "Write radiance.exr (RGBA), normal.exr, reflect.exr into this directory");
    cmd->add_flag("--no-ao", args->no_ao, "Turn ambient occlusion off (ao = 1); otherwise MODEL.ao from glint bake-ao is used when it matches the model, and the teapot is baked at start");
    cmd->add_option("--frames", args->frames, "Frames to render and time")->check(positive_number())->capture_default_str();
    cmd->add_option("--stats", args->stats, "Write frame-time statistics (median, p99, max ms) as JSON");
    cmd->add_option("--display", args->display, "headless, window, kms or auto")
        ->check(CLI::IsMember({"headless", "window", "kms", "auto"}))
        ->capture_default_str();
    cmd->add_option("--key", args->key, "Reinhard key value (middle grey), in (0, 1)")->capture_default_str();
    cmd->add_option("--threads", args->threads, "Worker threads of the convolution; 0 = all cores")
        ->check(non_negative_number())
        ->capture_default_str();
    cmd->add_option("--shadows", args->shadows,
                    "The object's shadow on the table, darkening the background: on, off, or auto (on over env or "
                    "an image, off over black)")
        ->check(CLI::IsMember({"on", "off", "auto"}))
        ->capture_default_str();
    cmd->add_option("--proxy", args->proxies,
                    "OBJ mesh of a real thing (world coordinates, object normalised to the unit sphere), drawn to "
                    "depth only so it hides the object; repeatable");
    cmd->add_option("--table-height", args->table_height,
                    "y of the table plane (world units); default: the model's lowest point");
    cmd->add_option("--msaa", args->msaa,
                    "Samples a pixel of the frame: 1 (none) or 4 (antialiased edges; the AOVs stay one sample a pixel)")
        ->check(CLI::IsMember({1, 4}))
        ->capture_default_str();
    cmd->add_option("--frame-targets", args->frame_targets,
                    "The frames' float targets: auto (RGBA32F where the GPU multisamples it, else RGBA16F), float "
                    "(RGBA32F) or half (RGBA16F: half the bytes; radiance capped at 65504); the AOVs are RGBA32F always")
        ->check(CLI::IsMember({"auto", "float", "half"}))
        ->capture_default_str();
    cmd->add_option("--camera", args->camera,
                    "Camera calibration (calibration.json of glint calibrate or glint simulate): the frame goes through "
                    "its response curve at --exposure-ms and --gain instead of Reinhard and sRGB, and an image "
                    "background is decoded with the inverse response");
    CLI::Option* exposure_option = cmd->add_option("--exposure-ms", args->exposure_ms,
                    "With --camera: the camera's exposure time, ms")->capture_default_str();
    CLI::Option* gain_option = cmd->add_option("--gain", args->gain, "With --camera: the camera's analogue gain")
        ->capture_default_str();
    cmd->add_flag("--camera-noise", args->camera_noise,
                  "With --camera: give the object the sensor's shot and read noise (the calibration's \"noise\": "
                  "full_well_electrons, read_noise), a new pattern each frame, so it matches the video");
    cmd->add_option("--motion-blur", args->motion_blur,
                    "DX,DY: smear the object along its motion on screen during the exposure, pixels (x right, y up; "
                    "at most 256), as the camera blurs the real scene");
    cmd->add_flag("--live-maps", args->live_maps,
                  "Start with coarse maps (32x16) and make the final ones (tolerance 1 %) with the GPU engine in each "
                  "frame's time left of --frame-budget-ms; the object switches to them when they are done");
    CLI::Option* budget_option = cmd->add_option("--frame-budget-ms", args->frame_budget_ms,
                    "With --live-maps: the frame period, ms; what a frame leaves of it goes to the convolution")
        ->capture_default_str();
    return {cmd, [args, material_option, exposure_option, gain_option, budget_option] {
                args->budget_given = budget_option->count() > 0;
                args->material_given = material_option->count() > 0;
                args->exposure_given = exposure_option->count() > 0;
                args->gain_given = gain_option->count() > 0;
                return run_render(*args);
            }};
}

}  // namespace glint::app
