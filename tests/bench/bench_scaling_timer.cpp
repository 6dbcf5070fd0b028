// In-process timing of the whole set (irradiance and n = 1 ... 20480) through convolve(), for
// A/B runs of the engine on a shared machine: the same call repeated, every repeat's wall time
// printed with its median and the per-map times of the median run. No files are written and no
// errors are measured (run_scaling_bench.sh and the accuracy tests do that).
//
//   glint_bench_scaling_timer MAP.exr [--reference-sizes | --size WxH] [--only N] [--repeats K] [--threads T]
//
// Without --reference-sizes the planner chooses every size (as `glint convolve` without
// --size); with it, each map is at its reference size (bench_util.hpp); --size fixes every map's. --only N runs the
// single map of shininess N (0 = irradiance). Run with GLIBC_TUNABLES=glibc.malloc.hugetlb=1 for
// the heap `glint convolve` uses (docs/convolution.md, "Huge pages").
#include <algorithm>
#include <chrono>
#include <ctime>
#include <cstdio>
#include <cstdlib>
#include <optional>
#include <string>
#include <vector>

#include "appliance/convolution/convolution.hpp"
#include "appliance/core/exr_io.hpp"
#include "appliance/core/memory.hpp"
#include "bench_util.hpp"

using namespace glint;
using namespace glint::convolution;

int main(int argc, char** argv) {
    std::string path;
    bool reference = false, fine_tiles = true;
    std::optional<double> only;
    std::optional<Size> size;
    int repeats = 5, threads = 2;
    for (int i = 1; i < argc; ++i) {
        const std::string a = argv[i];
        const auto value = [&] {
            if (i + 1 >= argc) {
                std::fprintf(stderr, "glint_bench_scaling_timer: %s needs a value\n", a.c_str());
                std::exit(2);
            }
            return std::string(argv[++i]);
        };
        if (a == "--help" || a == "-h") {
            std::printf("usage: glint_bench_scaling_timer MAP.exr [--reference-sizes | --size WxH] [--only N] "
                        "[--repeats K >= 1] [--threads T] [--whole-grids]\n"
                        "Times the whole set (irradiance and n = 1 ... 20480) through convolve() in this process, K\n"
                        "times: each repeat's wall and CPU time, their medians, and the per-map times of the median\n"
                        "run. --reference-sizes: each map at its reference size; --size: every map at WxH; without\n"
                        "either, the planner's sizes. --only N: the single map of shininess N (0 = irradiance).\n"
                        "Maps that need a finer grid get it only in tiles (Options::fine_tiles, glint convolve's\n"
                        "default); --whole-grids: the whole finer grid (glint convolve --no-fine-tiles).\n"
                        "Run with GLIBC_TUNABLES=glibc.malloc.hugetlb=1 for the heap glint convolve uses.\n");
            return 0;
        }
        if (a == "--reference-sizes") reference = true;
        else if (a == "--whole-grids") fine_tiles = false;
        else if (a == "--only") only = std::atof(value().c_str());
        else if (a == "--size") {
            const std::string v = value();
            int w = 0, h = 0;
            if (std::sscanf(v.c_str(), "%dx%d", &w, &h) != 2 || w <= 0 || h <= 0) {
                std::fprintf(stderr, "glint_bench_scaling_timer: --size takes WxH, not '%s'\n", v.c_str());
                return 2;
            }
            size = Size{w, h};
        }
        else if (a == "--repeats") repeats = std::atoi(value().c_str());
        else if (a == "--threads") threads = std::atoi(value().c_str());
        else if (!a.empty() && a[0] != '-' && path.empty()) path = a;
        else {
            std::fprintf(stderr, "glint_bench_scaling_timer: unknown argument '%s'\n", a.c_str());
            return 2;
        }
    }
    if (path.empty() || repeats < 1) {
        std::fprintf(stderr, "usage: glint_bench_scaling_timer MAP.exr [--reference-sizes] [--only N] "
                             "[--repeats K >= 1] [--threads T]\n");
        return 2;
    }
    keep_freed_memory();
    const HdrImage env = load_exr(path).image;
    std::vector<MapRequest> maps;
    if (!only || *only == 0) {
        maps.push_back(MapRequest::make_irradiance());
        if (reference) maps.back().size = bench::reference_size(1);
    }
    for (double n : bench::whole_set_shininess()) {
        if (only && *only != n) continue;
        maps.push_back(MapRequest::make_phong(n, std::to_string(int(n))));
        if (reference) maps.back().size = bench::reference_size(n);
    }
    if (maps.empty()) {
        std::fprintf(stderr, "glint_bench_scaling_timer: --only names no map of the whole set\n");
        return 2;
    }
    Options options;
    options.threads = threads;
    options.size = size;
    options.fine_tiles = fine_tiles;
    // Process CPU time too: on a machine shared with other jobs the wall time follows their load,
    // the CPU time much less (it still includes the kernel's page faults).
    const auto cpu_now = [] {
        timespec t{};
        clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &t);
        return double(t.tv_sec) + 1e-9 * double(t.tv_nsec);
    };
    std::vector<double> walls, cpus;
    std::vector<std::vector<MapResult>> runs;
    for (int k = 0; k < repeats; ++k) {
        const auto start = std::chrono::steady_clock::now();
        const double cpu_start = cpu_now();
        std::vector<MapResult> results = convolve(env, maps, options);
        walls.push_back(std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count());
        cpus.push_back(cpu_now() - cpu_start);
        for (MapResult& r : results) {  // keep the timings only
            r.image = HdrImage();
            r.fine = FineTiles{};
        }
        runs.push_back(std::move(results));
    }
    std::vector<double> sorted = walls;
    std::sort(sorted.begin(), sorted.end());
    const double median = sorted[sorted.size() / 2];
    const std::size_t at = std::size_t(std::find(walls.begin(), walls.end(), median) - walls.begin());
    std::vector<double> cpu_sorted = cpus;
    std::sort(cpu_sorted.begin(), cpu_sorted.end());
    std::printf("%s %s, %d threads: median %.4f s, min %.4f s, CPU median %.4f s; wall", path.c_str(),
                reference ? "reference sizes" : size ? "fixed size" : "planner's sizes", threads, median, sorted.front(),
                cpu_sorted[cpu_sorted.size() / 2]);
    for (double w : walls) std::printf(" %.4f", w);
    std::printf(", CPU");
    for (double c : cpus) std::printf(" %.4f", c);
    std::printf("\n");
    for (const MapResult& r : runs[at])
        std::printf("  %-12s %-5s %5dx%-5d sum %5dx%-5d %.4f s patched %lld  predicted %.2g%s\n",
                    r.request.label.c_str(), to_string(r.plan.method).c_str(), r.plan.output_size.width,
                    r.plan.output_size.height, r.plan.sum_size.width, r.plan.sum_size.height, r.seconds,
                    r.patched_texels, r.plan.predicted_error, r.plan.size_reason.find("tiles of") != std::string::npos ? "  (fine tiles)" : "");
    return 0;
}
