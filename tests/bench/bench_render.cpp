// The renderer's part-4 benchmark (issue 15; docs/render.md "Benchmark"), the measurements that
// need the renderer in-process. Frame times are measured by run_render_bench.sh through
// `glint render --stats`.
//
//   glint_bench_render shading --world NAME [--size 1280x720]
//     (b) the radiance AOV of a matte and a glossy (n = 160) sphere, shaded with the maps
//     `glint render` would make (auto, tolerance 1 %), against the exact maps of the same sizes
//     looked up at the AOVs' own normal and reflection direction: weighted relative RMS and worst
//     pixel. The world is Blender's, averaged over 4x4 blocks to 256x128 (exact maps of the
//     1024x512 input take minutes; the block mean keeps every light's power).
//
//   glint_bench_render consistency --truth ENV.exr --captured C.exr --calibration CAL.json [--size 640x360]
//     (c) the same spheres lit by the maps of a simulated capture (auto maps of C.exr, as the
//     appliance would make them) against the spheres shaded from the exact maps of the true
//     environment (block-averaged to 256x128, exact maps at the captured maps' sizes), both
//     through the same camera model: the session's response curve (CAL.json, capture's format)
//     with one exposure for both, set so that the truth's mean object luminance gives code 118
//     (the simulator's auto-exposure target). Relative error of the code values (real-valued,
//     before quantisation) per pixel, mean over channels: mean and p95 over the object.
//
// Prints one markdown table row per material on stdout.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <string>
#include <vector>

#include "appliance/capture/calibration_io.hpp"
#include "appliance/convolution/convolution.hpp"
#include "appliance/core/equirect.hpp"
#include "appliance/core/errors.hpp"
#include "appliance/core/exr_io.hpp"
#include "appliance/gl/gl_context.hpp"
#include "appliance/render/maps.hpp"
#include "appliance/render/material.hpp"
#include "appliance/render/mesh.hpp"
#include "appliance/render/renderer.hpp"
#include "tests/gpu/render_worlds.hpp"

namespace glint {
namespace {

namespace fs = std::filesystem;

render::ShadingMaps maps_of(const HdrImage& env, const render::Material& m, convolution::Method method,
                            std::optional<convolution::Size> size = std::nullopt) {
    convolution::Options o;
    o.method = method;
    o.tolerance = 0.01;
    o.size = size;
    o.threads = 2;
    return render::convolve_maps(env, m, o);
}

const HdrImage& map_used(const render::ShadingMaps& maps, const render::Material& m) {
    return m.diffuse() ? *maps.irradiance : *maps.reflection();
}

render::Aovs render_sphere(const render::Material& m, const render::ShadingMaps& maps, int w, int h) {
    render::Renderer r(render::make_uv_sphere(), m, maps, w, h);
    r.set_background_black();
    r.draw_scene();
    return r.read_aovs();
}

// kd E_d(N) + ks E_s(R) from `maps`, looked up (core's bilinear lookup) at pixel k's directions.
glm::dvec3 shade(const render::Aovs& a, std::size_t k, const render::Material& m, const render::ShadingMaps& maps) {
    const glm::dvec3 n(a.normal[4 * k], a.normal[4 * k + 1], a.normal[4 * k + 2]);
    const glm::dvec3 r(a.reflect[4 * k], a.reflect[4 * k + 1], a.reflect[4 * k + 2]);
    glm::dvec3 e(0.0);
    if (m.diffuse()) {
        const Rgb d = sample_bilinear(*maps.irradiance, n);
        e += m.kd * glm::dvec3(d.r, d.g, d.b);
    }
    if (m.specular()) {
        const Rgb s = sample_bilinear(*maps.reflection(), r);
        e += m.ks * glm::dvec3(s.r, s.g, s.b);
    }
    return e;
}

void parse_size(const std::string& text, int& w, int& h) {
    if (std::sscanf(text.c_str(), "%dx%d", &w, &h) != 2 || w < 1 || h < 1) throw InputError("--size " + text + ": want WxH");
}

int shading(const std::string& world, int w, int h) {
    const HdrImage env = test::small_blender_world(world);
    for (const char* spec : {"matte", "glossy:160"}) {
        const render::Material m = render::parse_material(spec);
        const render::ShadingMaps used = maps_of(env, m, convolution::Method::Auto);
        const HdrImage& u = map_used(used, m);
        const render::ShadingMaps exact =
            maps_of(env, m, convolution::Method::Exact, convolution::Size{u.width(), u.height()});
        const render::Aovs a = render_sphere(m, used, w, h);
        double num = 0, den = 0, mean = 0;
        std::vector<std::pair<double, double>> values;  // (rendered, exact) per channel
        for (std::size_t k = 0; k < std::size_t(w) * std::size_t(h); ++k) {
            if (a.radiance[4 * k + 3] == 0) continue;
            const glm::dvec3 e = shade(a, k, m, exact);
            for (int c = 0; c < 3; ++c) values.emplace_back(a.radiance[4 * k + std::size_t(c)], e[c]);
        }
        for (const auto& [x, y] : values) {
            num += (x - y) * (x - y);
            den += y * y;
            mean += std::abs(y);
        }
        mean /= double(std::max<std::size_t>(1, values.size()));
        double worst = 0;
        for (const auto& [x, y] : values) worst = std::max(worst, std::abs(x - y) / std::max(std::abs(y), mean));
        std::printf("| %s | %s | %dx%d | %zu | %s | %.3f %% | %.3f %% |\n", world.c_str(), spec, w, h, values.size() / 3,
                    used.irradiance ? used.irradiance_from.c_str() : used.reflection_from().c_str(),
                    100 * std::sqrt(num / den), 100 * worst);
        std::fflush(stdout);
    }
    return 0;
}

int consistency(const fs::path& truth_path, const fs::path& captured_path, const fs::path& calibration_path, int w,
                int h) {
    const HdrImage truth = test::block_mean(load_exr(truth_path).image, 4);
    const HdrImage captured = load_exr(captured_path).image;
    const capture::CameraCalibration cal = capture::load_calibration(calibration_path);
    if (!(cal.response.gamma > 0)) throw InputError(calibration_path.string() + ": the bench needs a parametric response");
    for (const char* spec : {"matte", "glossy:160"}) {
        const render::Material m = render::parse_material(spec);
        const render::ShadingMaps from_capture = maps_of(captured, m, convolution::Method::Auto);
        const HdrImage& u = map_used(from_capture, m);
        const render::ShadingMaps exact =
            maps_of(truth, m, convolution::Method::Exact, convolution::Size{u.width(), u.height()});
        const render::Aovs a = render_sphere(m, from_capture, w, h);
        const render::Aovs t = render_sphere(m, exact, w, h);
        // One exposure for both: the truth's mean object luminance at code 118.
        double sum_l = 0;
        long long count = 0;
        for (std::size_t k = 0; k < std::size_t(w) * std::size_t(h); ++k) {
            if (t.radiance[4 * k + 3] == 0) continue;
            sum_l += 0.2126 * t.radiance[4 * k] + 0.7152 * t.radiance[4 * k + 1] + 0.0722 * t.radiance[4 * k + 2];
            ++count;
        }
        // forward(X) = 118 for X = ...: solve by bisection on the monotone curve.
        double lo = 1e-9, hi = 1e3;
        for (int it = 0; it < 200; ++it) {
            const double mid = std::sqrt(lo * hi);
            (cal.response.forward(mid) < 118 ? lo : hi) = mid;
        }
        const double scale = lo / (sum_l / double(count));  // X per unit radiance
        std::vector<double> errors;
        for (std::size_t k = 0; k < std::size_t(w) * std::size_t(h); ++k) {
            if (t.radiance[4 * k + 3] == 0 || a.radiance[4 * k + 3] == 0) continue;
            double e = 0;
            for (int c = 0; c < 3; ++c) {
                const double zt = cal.response.forward(scale * t.radiance[4 * k + std::size_t(c)]);
                const double za = cal.response.forward(scale * a.radiance[4 * k + std::size_t(c)]);
                e += std::abs(za - zt) / std::max(zt, 1.0) / 3.0;
            }
            errors.push_back(e);
        }
        std::sort(errors.begin(), errors.end());
        double mean = 0;
        for (double e : errors) mean += e;
        mean /= double(std::max<std::size_t>(1, errors.size()));
        const double p95 = errors.empty() ? 0 : errors[std::min(errors.size() - 1, std::size_t(0.95 * double(errors.size())))];
        std::printf("| %s | %s | %dx%d | %zu | %s | %.2f %% | %.2f %% |\n", truth_path.stem().c_str(), spec, w, h,
                    errors.size(), (from_capture.irradiance ? from_capture.irradiance_from : from_capture.reflection_from()).c_str(),
                    100 * mean, 100 * p95);
        std::fflush(stdout);
    }
    return 0;
}

int run(int argc, char** argv) {
    if (argc < 2) throw InputError("usage: glint_bench_render shading|consistency ...");
    const std::string mode = argv[1];
    std::string world, truth, captured, calibration, size = mode == "shading" ? "1280x720" : "640x360";
    for (int i = 2; i + 1 < argc; i += 2) {
        const std::string flag = argv[i], value = argv[i + 1];
        if (flag == "--world") world = value;
        else if (flag == "--truth") truth = value;
        else if (flag == "--captured") captured = value;
        else if (flag == "--calibration") calibration = value;
        else if (flag == "--size") size = value;
        else throw InputError("unknown flag " + flag);
    }
    int w = 0, h = 0;
    parse_size(size, w, h);
    gl::EglDisplay display = gl::EglDisplay::surfaceless();
    gl::GlContext context(display);
    context.make_current();
    if (mode == "shading") {
        if (world.empty()) throw InputError("shading: --world NAME");
        return shading(world, w, h);
    }
    if (mode == "consistency") {
        if (truth.empty() || captured.empty() || calibration.empty())
            throw InputError("consistency: --truth ENV.exr --captured C.exr --calibration CAL.json");
        return consistency(truth, captured, calibration, w, h);
    }
    throw InputError("unknown mode " + mode + " (shading, consistency)");
}

}  // namespace
}  // namespace glint

int main(int argc, char** argv) {
    try {
        return glint::run(argc, argv);
    } catch (const glint::InputError& e) {
        std::fprintf(stderr, "glint_bench_render: %s\n", e.what());
        return 2;
    } catch (const std::exception& e) {
        std::fprintf(stderr, "glint_bench_render: %s\n", e.what());
        return 1;
    }
}
