// Generated maps that none of the planner's constants were set on, through the whole set at the
// planner's own sizes, each map judged off-grid (offgrid.hpp): a 3-texel checkerboard at 100:1
// with 50 suns of 1e4, one 1e6 sun on a 1e-3 floor, 2000x1000 noise (off the power-of-two
// ladder), and four area lights of 150-2000 over dozens of rows. Prints a table; no files. Run: build/tests/bench/glint_bench_stress_maps
// (with GLIBC_TUNABLES=glibc.malloc.hugetlb=1 for the heap glint convolve uses).
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <random>
#include <string>

#include "appliance/convolution/convolution.hpp"
#include "appliance/convolution/offgrid.hpp"
#include "appliance/core/memory.hpp"

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

}  // namespace

int main(int argc, char** argv) {
    bool fine_tiles = true;
    for (int i = 1; i < argc; ++i) {
        const std::string a = argv[i];
        if (a == "--whole-grids") {
            fine_tiles = false;
            continue;
        }
        if (a != "--help" && a != "-h") {
            std::fprintf(stderr, "glint_bench_stress_maps: unknown argument '%s' (--help)\n", a.c_str());
            return 2;
        }
        std::printf("glint_bench_stress_maps [--whole-grids]: the whole set (irradiance, n = 10, 40, 160, 1280, 5120,\n"
                    "20480, 2e5, 1e6, 1e7) of four generated maps at the planner's sizes, each map's bilinear\n"
                    "lookups judged at 1024 random directions against the conventions' sum (predicted, off-grid\n"
                    "RMS +- its standard error, worst). Maps that need a finer grid get it in fine tiles, as glint\n"
                    "convolve delivers them, and are read through the tiles; --whole-grids: the whole finer grid.\n");
        return 0;
    }
    keep_freed_memory();
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
            const std::string tiles =
                r.fine.empty() ? "" : " + " + std::to_string(r.fine.count()) + " tiles " + std::to_string(r.fine.factor) + "x";
            std::printf("  %-11s %-9s%-14s predicted %.4f  off-grid %.2e +- %.1e  worst %.2e%s\n",
                        r.request.label.c_str(), to_string(r.plan.output_size).c_str(), tiles.c_str(),
                        r.plan.predicted_error, e.weighted_relative_rms, e.rms_standard_error, e.worst_texel,
                        r.plan.predicted_error > o.tolerance ? "  over" : "");
        }
    }
    return 0;
}
