// Generated maps that none of the planner's constants were set on, through the whole set at the
// planner's own sizes, each map judged off-grid (offgrid.hpp): a 3-texel checkerboard at 100:1
// with 50 suns of 1e4, one 1e6 sun on a 1e-3 floor, 2000x1000 noise (off the power-of-two
// ladder), and four area lights of 150-2000 over dozens of rows. Prints a table; no files. Run: build/tests/bench/glint_bench_stress_maps
// (with GLIBC_TUNABLES=glibc.malloc.hugetlb=1 for the heap glint convolve uses).
// --photo WxH: instead, a photograph-like map made at that size (detail at every scale down to its
// texels, a sun, lamps, a window), not upsampled from a smaller one as the scaling benchmark's
// inputs are: issue 13's whole set at the planner's sizes, its time, the process's peak memory,
// and each map judged off-grid (--judge K directions, 0 for none).
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <cstdio>
#include <optional>
#include <random>
#include <string>

#include "appliance/convolution/convolution.hpp"
#include "appliance/convolution/offgrid.hpp"
#include "appliance/core/equirect.hpp"
#include "appliance/core/exr_io.hpp"
#include "appliance/core/memory.hpp"
#include "appliance/core/parallel.hpp"
#include "bench_util.hpp"

using namespace glint;
using namespace glint::convolution;

namespace {

enum class Kind { CheckerWithSuns, OneSun, Noise, Panels };

HdrImage make_map(Kind kind, Size size) {
    HdrImage m(size.width, size.height);
    std::mt19937 rng(unsigned(kind) * 7 + 1);
    std::uniform_real_distribution<float> u(0, 1);
    for (int j = 0; j < size.height; ++j)
        for (int i = 0; i < size.width; ++i) {
            float v = 0.2f + u(rng) * u(rng) * 3;
            if (kind == Kind::CheckerWithSuns) v = ((i / 3 + j / 3) % 2) ? 1.0f : 0.01f;
            if (kind == Kind::OneSun) v = 1e-3f;
            m.set(i, j, {v, 0.7f * v, 0.4f * v});
        }
    if (kind == Kind::CheckerWithSuns)
        for (int s = 0; s < 50; ++s) m.set(int(rng() % unsigned(size.width)), int(rng() % unsigned(size.height)), {1e4f, 9e3f, 8e3f});
    if (kind == Kind::OneSun) m.set(size.width / 3, size.height / 4, {1e6f, 1e6f, 9e5f});
    if (kind == Kind::Panels) {
        // Area lights over many rows, as in a photo studio: more bright texels than the split takes,
        // on dozens of rows (the SH fold's row-by-row projection), one across the seam, one at a pole.
        const auto panel = [&](int i0, int j0, int w, int h, Rgb v) {
            for (int j = std::max(0, j0); j < std::min(size.height, j0 + h); ++j)
                for (int i = i0; i < i0 + w; ++i) m.set(((i % size.width) + size.width) % size.width, j, v);
        };
        for (int j = 0; j < size.height; ++j)
            for (int i = 0; i < size.width; ++i) {
                const float v = 0.05f + 0.3f * float(j) / float(size.height) + 0.02f * u(rng);
                m.set(i, j, {v, 0.9f * v, 0.8f * v});
            }
        panel(size.width / 8, size.height / 5, size.width / 40, size.height / 6, {800, 780, 700});
        panel(size.width / 2, size.height / 3, size.width / 10, size.height / 60 + 1, {2e3f, 2e3f, 2.1e3f});
        panel(-size.width / 50, size.height / 4, size.width / 25, size.width / 25, {300, 320, 350});
        panel(0, 0, size.width, size.height / 80 + 1, {150, 150, 160});
    }
    return m;
}


// Lattice value noise in 3-D, smooth (quintic fade), in [-1, 1]: read at a unit direction times a
// frequency it is seamless across the equirect seam and smooth at the poles.
double hash01(std::int64_t x, std::int64_t y, std::int64_t z, std::uint32_t seed) {
    std::uint64_t h = std::uint64_t(x) * 0x9E3779B97F4A7C15ull ^ std::uint64_t(y) * 0xC2B2AE3D27D4EB4Full ^
                      std::uint64_t(z) * 0x165667B19E3779F9ull ^ std::uint64_t(seed) * 0x27D4EB2F165667C5ull;
    h ^= h >> 31;
    h *= 0xBF58476D1CE4E5B9ull;
    h ^= h >> 29;
    return double(h >> 11) * (1.0 / 9007199254740992.0) * 2.0 - 1.0;
}

double value_noise(const glm::dvec3& p, std::uint32_t seed) {
    const glm::dvec3 f = glm::floor(p);
    const glm::dvec3 t = p - f;
    const glm::dvec3 u = t * t * t * (t * (t * 6.0 - 15.0) + 10.0);
    const auto x0 = std::int64_t(f.x), y0 = std::int64_t(f.y), z0 = std::int64_t(f.z);
    double acc = 0;
    for (int c = 0; c < 8; ++c) {
        const int dx = c & 1, dy = (c >> 1) & 1, dz = c >> 2;
        const double w = (dx ? u.x : 1 - u.x) * (dy ? u.y : 1 - u.y) * (dz ? u.z : 1 - u.z);
        acc += w * hash01(x0 + dx, y0 + dy, z0 + dz, seed);
    }
    return acc;
}

// A map with what a photograph of a room with a view holds, made at its own size: brightness
// varying at every scale from 90 degrees down to the texel (octaves of value noise in log
// radiance, amplitude halving with the wavelength: a 1/f spectrum), a brighter sky over the
// horizon, a window of 40, six lamps of 0.5-2 degrees at 300-3000 (two near the poles, one on the
// seam) and a sun of 0.27 degrees at 5e4 with a glow. None of the planner's constants was set on it.
HdrImage make_photo_like(Size size) {
    HdrImage m(size.width, size.height, HdrImage::Unwritten{});
    struct Light {
        glm::dvec3 dir;
        double radius, value;
        Rgb tint;
    };
    const auto toward = [](double elevation_deg, double azimuth_deg) {
        return direction_from_angles((90.0 - elevation_deg) * kPi / 180.0, azimuth_deg * kPi / 180.0);
    };
    const Light lights[] = {{toward(20, 40), 0.27, 5e4, {1.0f, 0.93f, 0.8f}},
                            {toward(55, -120), 1.5, 800, {1.0f, 0.9f, 0.7f}},
                            {toward(84, 10), 2.0, 300, {0.9f, 0.95f, 1.0f}},
                            {toward(-80, 100), 0.8, 1500, {1.0f, 0.8f, 0.6f}},
                            {toward(10, 179.9), 0.5, 3000, {1.0f, 1.0f, 1.0f}},
                            {toward(30, -60), 1.0, 600, {0.8f, 0.9f, 1.0f}},
                            {toward(5, 90), 0.7, 2000, {1.0f, 0.85f, 0.7f}}};
    const glm::dvec3 sun = lights[0].dir;
    const double texel_deg = 180.0 / size.height;
    const int octaves = std::max(1, int(std::ceil(std::log2(90.0 / texel_deg))));
    parallel_for(size.height, 2, [&](int j) {
        for (int i = 0; i < size.width; ++i) {
            const glm::dvec3 d = texel_direction(i, j, size.width, size.height);
            double log_l = 0, amplitude = 0.9, frequency = 1.3;
            for (int o = 0; o < octaves; ++o, amplitude *= 0.5, frequency *= 2)
                log_l += amplitude * value_noise(d * frequency + double(o) * 17.0, std::uint32_t(o + 1));
            double v = std::exp(log_l) * (d.y > 0 ? 1.5 + 2.0 * d.y : 0.4);
            const double az = std::atan2(d.x, -d.z) * 180.0 / kPi, el = std::asin(d.y) * 180.0 / kPi;
            if (el > 5 && el < 35 && az > -150 && az < -110) v += 40;  // a window
            Rgb c{float(v), float(0.9 * v), float(0.75 * v)};
            v = 0;
            const double to_sun = std::acos(std::clamp(glm::dot(d, sun), -1.0, 1.0)) * 180.0 / kPi;
            v += 200.0 * std::exp(-to_sun / 2.0);  // the sun's glow
            c.r += float(v), c.g += float(0.9 * v), c.b += float(0.7 * v);
            for (const Light& l : lights) {
                const double a = std::acos(std::clamp(glm::dot(d, l.dir), -1.0, 1.0)) * 180.0 / kPi;
                if (a > l.radius + texel_deg) continue;
                // Anti-aliased disc edge: the share of the texel inside, over its width.
                const double inside = std::clamp((l.radius - a) / texel_deg + 0.5, 0.0, 1.0);
                c.r += float(inside * l.value * l.tint.r);
                c.g += float(inside * l.value * l.tint.g);
                c.b += float(inside * l.value * l.tint.b);
            }
            m.set(i, j, c);
        }
    });
    return m;
}

// " + K tiles Fx" for a map delivered with fine tiles, else "".
std::string tiles_note(const MapResult& r) {
    return r.fine.empty() ? "" : " + " + std::to_string(r.fine.count()) + " tiles " + std::to_string(r.fine.factor) + "x";
}

int run_photo(Size size, int judge, bool fine_tiles) {
    std::vector<MapRequest> maps{MapRequest::make_irradiance()};
    for (double n : bench::whole_set_shininess()) maps.push_back(MapRequest::make_phong(n, std::to_string(int(n))));
    Options o;
    o.threads = 2;
    o.fine_tiles = fine_tiles;  // as glint convolve delivers them
    auto made = std::chrono::steady_clock::now();
    HdrImage env = make_photo_like(size);
    const double make_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - made).count();
    const double before = bench::peak_rss_mib();
    const auto start = std::chrono::steady_clock::now();
    const std::vector<MapResult> results = convolve(std::move(env), maps, o);  // handed over, as glint convolve does
    const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    std::printf("photo-like %s (made in %.1f s): whole set %.2f s, peak RSS %.0f MiB (%.0f MiB before convolve)\n",
                to_string(size).c_str(), make_s, seconds, bench::peak_rss_mib(), before);
    const HdrImage judge_env = judge > 0 ? make_photo_like(size) : HdrImage();
    for (const MapResult& r : results) {
        std::printf("  %-11s %-10s%-16s %-6s %6.3f s  predicted %.4f", r.request.label.c_str(),
                    to_string(r.plan.output_size).c_str(), tiles_note(r).c_str(), to_string(r.plan.method).c_str(), r.seconds,
                    r.plan.predicted_error);
        if (judge > 0) {
            const OffGridError e =
                measure_offgrid_error(judge_env, r.image, r.request.shininess, judge, 5, 2, r.plan.lookup, &r.fine);
            std::printf("  off-grid %.2e +- %.1e  worst %.2e", e.weighted_relative_rms, e.rms_standard_error,
                        e.worst_texel);
        }
        std::printf("%s\n", r.plan.predicted_error > o.tolerance ? "  over" : "");
        if (std::getenv("GLINT_STRESS_REASONS")) std::printf("    %s\n", r.plan.size_reason.c_str());
        std::fflush(stdout);
    }
    return 0;
}

}  // namespace

int main(int argc, char** argv) {
    bool fine_tiles = true;
    std::optional<Size> photo;
    int judge = 256;
    bool judge_given = false;
    std::string write_to;
    for (int i = 1; i < argc; ++i) {
        const std::string a = argv[i];
        if (a == "--whole-grids") {
            fine_tiles = false;
            continue;
        }
        if (a == "--write" && i + 1 < argc) {
            write_to = argv[++i];
            continue;
        }
        if ((a == "--photo" || a == "--judge") && i + 1 < argc) {
            const std::string v = argv[++i];
            if (a == "--judge") {
                judge = std::atoi(v.c_str());
                judge_given = true;
                continue;
            }
            int w = 0, h = 0;
            char rest = 0;
            if (std::sscanf(v.c_str(), "%dx%d%c", &w, &h, &rest) != 2 || w < 8 || h < 4) {
                std::fprintf(stderr, "glint_bench_stress_maps: --photo takes WxH (at least 8x4), not '%s'\n", v.c_str());
                return 2;
            }
            photo = Size{w, h};
            continue;
        }
        if (a != "--help" && a != "-h") {
            std::fprintf(stderr, "glint_bench_stress_maps: unknown argument '%s' (--help)\n", a.c_str());
            return 2;
        }
        std::printf("glint_bench_stress_maps --photo WxH [--judge K]: a photograph-like map made at WxH (detail\n"
                    "at every scale, a sun of 5e4, lamps, a window): issue 13's whole set (irradiance, n = 1 ... 20480)\n"
                    "at the planner's sizes with the map handed over, its time and the process's peak RSS, each map\n"
                    "judged at K random directions off-grid (default 256; 0: not judged). --write FILE.exr: only write\n"
                    "the map, for glint convolve.\n");
        std::printf("glint_bench_stress_maps [--whole-grids]: the whole set (irradiance, n = 10, 40, 160, 1280, 5120,\n"
                    "20480, 2e5, 1e6, 1e7) of four generated maps at the planner's sizes, each map's bilinear\n"
                    "lookups judged at 1024 random directions against the conventions' sum (predicted, off-grid\n"
                    "RMS +- its standard error, worst). Maps that need a finer grid get it in fine tiles, as glint\n"
                    "convolve delivers them, and are read through the tiles; --whole-grids: the whole finer grid.\n");
        return 0;
    }
    if (!photo && (!write_to.empty() || judge_given)) {
        std::fprintf(stderr, "glint_bench_stress_maps: --write and --judge go with --photo WxH (--help)\n");
        return 2;
    }
    keep_freed_memory();
    if (photo && !write_to.empty()) {
        save_exr(write_to, make_photo_like(*photo));
        std::printf("wrote %s (%s)\n", write_to.c_str(), to_string(*photo).c_str());
        return 0;
    }
    if (photo) return run_photo(*photo, judge, fine_tiles);
    const struct {
        Kind kind;
        const char* name;
        Size size;
    } cases[] = {{Kind::CheckerWithSuns, "checkerboard 100:1 with 50 suns", {1024, 512}},
                 {Kind::OneSun, "one 1e6 sun on 1e-3", {1024, 512}},
                 {Kind::Noise, "noise", {2000, 1000}},
                 {Kind::Panels, "four area lights on a dim gradient", {1024, 512}}};
    for (const auto& c : cases) {
        const HdrImage env = make_map(c.kind, c.size);
        std::vector<MapRequest> maps{MapRequest::make_irradiance()};
        for (double n : {10.0, 40.0, 160.0, 1280.0, 5120.0, 20480.0, 2e5, 1e6, 1e7})
            maps.push_back(MapRequest::make_phong(n, std::to_string(int(n))));
        Options o;
        o.threads = 2;
        o.fine_tiles = fine_tiles;
        const auto start = std::chrono::steady_clock::now();
        const std::vector<MapResult> results = convolve(env, maps, o);
        const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
        std::printf("%s %s: whole set %.2f s\n", c.name, to_string(c.size).c_str(), seconds);
        for (const MapResult& r : results) {
            const OffGridError e =
                measure_offgrid_error(env, r.image, r.request.shininess, 1024, 5, 2, r.plan.lookup, &r.fine);
            std::printf("  %-11s %-9s%-14s predicted %.4f  off-grid %.2e +- %.1e  worst %.2e%s\n",
                        r.request.label.c_str(), to_string(r.plan.output_size).c_str(), tiles_note(r).c_str(),
                        r.plan.predicted_error, e.weighted_relative_rms, e.rms_standard_error, e.worst_texel,
                        r.plan.predicted_error > o.tolerance ? "  over" : "");
        }
    }
    return 0;
}
