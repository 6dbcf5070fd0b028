// How `glint convolve` scales with the input's size (docs/convolution.md). For
// each environment map and each input size from 256x128 to 8192x4096, the whole
// set (irradiance and n = 1 ... 20480) is computed by the product CLI in its own
// process, with the planner's own output sizes; the program measures the
// process's wall time and peak resident memory, reads report.json (load and
// convolution times, each map's plan) and measures every map against `exact`.
//
// Inputs: the 1024x512 blender-data maps as they are; 256x128 and 512x256 by
// solid-angle-weighted box averaging (4x4, 2x2); 2048x1024 ... 8192x4096 by
// nearest-neighbour upsampling (each texel repeated 2x2, 4x4, 8x8). An exact sum
// of every map over an 8K input takes hours, but an NN-upsampled map is the same
// piecewise-constant radiance as its source, so every NN-upsampled version has the
// same integrals and differs only in the quadrature (one midpoint per texel), which
// converges as the texel size squared. Each map's reference for an upsampled input
// is exact from the finest version up to the input itself that fits a budget of
// multiply-adds (reference_source): at 8192x4096, the 128x64 maps and n = 20480 from
// the input itself, the others from 4096x2048 or 2048x1024.
// The difference between the 1024x512 and 2048x1024 quadratures is measured on
// courtyard. For the detail map (courtyard) each map's "lookup floor" is measured
// too: exact on the map's own output grid against the same reference, i.e. what
// bilinear lookups on that grid cost by themselves, apart from the sums.
//
// glint runs with --allow-over-tolerance, so a map predicted over tolerance is
// written and marked in report.json instead of failing the whole run.
//
// Writes <out>/scaling.md, <out>/scaling.csv and, with gnuplot,
// <images>/convolution_scaling.png. Inputs, exact references and the plot's
// data are cached in --cache.
#include <fcntl.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <map>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "appliance/convolution/convolution.hpp"
#include "appliance/core/equirect.hpp"
#include "appliance/core/error_metrics.hpp"
#include "appliance/core/errors.hpp"
#include "appliance/core/exr_io.hpp"
#include "appliance/core/fine_tiles_io.hpp"
#include "bench_util.hpp"

namespace fs = std::filesystem;
using namespace glint;
using namespace glint::convolution;

using glint::bench::fmt;
using glint::bench::machine_description;
using glint::bench::reference_size;

namespace {

const std::vector<std::string> kMaps{"courtyard", "studio", "sunset"};
const std::vector<Size> kSizes{{256, 128}, {512, 256}, {1024, 512}, {2048, 1024}, {4096, 2048}, {8192, 4096}};
constexpr Size kSourceSize{1024, 512};

std::string size_str(Size s) { return glint::convolution::to_string(s); }
bool same(Size a, Size b) { return a.width == b.width && a.height == b.height; }
double texels(Size s) { return double(s.width) * double(s.height); }

std::optional<Size> parse_size(const std::string& s) {
    int w = 0, h = 0;
    char x = 0, rest = 0;
    if (std::sscanf(s.c_str(), "%d%c%d%c", &w, &x, &h, &rest) != 3 || x != 'x') return std::nullopt;
    for (Size k : kSizes)
        if (k.width == w && k.height == h) return k;
    return std::nullopt;
}

std::vector<std::string> split(const std::string& s, char sep) {
    std::vector<std::string> out;
    std::string item;
    std::istringstream in(s);
    while (std::getline(in, item, sep))
        if (!item.empty()) out.push_back(item);
    return out;
}

[[noreturn]] void usage_error(const std::string& message) {
    std::fprintf(stderr, "bench_scaling: %s (see --help)\n", message.c_str());
    std::exit(2);
}

struct Run {
    std::string map;
    Size input;
};

struct Config {
    fs::path worlds = "/usr/share/blender/datafiles/studiolights/world";
    fs::path cache = "build/bench-cache/scaling";
    fs::path exact_cache = "build/bench-cache";  // glint_bench_convolution's exact maps of the 1024x512 inputs
    fs::path out = "tests/bench/results";
    fs::path images = "images";
    std::string glint = "build/appliance/app/glint";
    std::string quadrature_map = "courtyard";
    int threads = 2;
    bool keep_outputs = false;
    bool quadrature = true;
    bool whole_grids = false;  // glint convolve --no-fine-tiles; results named *_whole_grids
    std::string suffix() const { return whole_grids ? "_whole_grids" : ""; }
    std::vector<Run> runs;
};

const char* kHelp =
    "glint_bench_scaling [--run MAP:SIZES]... [--preset full|issue] [--worlds DIR] [--cache DIR]\n"
    "                    [--exact-cache DIR] [--out DIR] [--images DIR] [--glint PATH] [--threads N]\n"
    "                    [--quadrature-map NAME] [--no-quadrature] [--keep-outputs] [--whole-grids]\n"
    "\n"
    "How `glint convolve` scales with the input size. For each (map, input size) the whole set\n"
    "(--irradiance --shininess 1,10,20,40,80,160,320,640,1280,5120,20480 --allow-over-tolerance,\n"
    "the planner's own output sizes) runs as a subprocess; wall time, peak RSS (wait4), report.json's load and\n"
    "convolution times, and every map's error against exact are reported.\n"
    "\n"
    "  --run MAP:SIZES   a map (courtyard, studio, sunset) at the listed input sizes, comma\n"
    "                    separated (256x128 512x256 1024x512 2048x1024 4096x2048 8192x4096) or\n"
    "                    'all'; repeatable; replaces the preset. Example:\n"
    "                    --run courtyard:256x128,1024x512 --run studio:1024x512\n"
    "  --preset P        full (default): every map at every size (18 runs);\n"
    "                    issue: courtyard at every size, studio and sunset at 1024x512, 4096x2048\n"
    "  --worlds DIR      the blender studiolights/world directory (courtyard.exr, ...)\n"
    "                    [/usr/share/blender/datafiles/studiolights/world]\n"
    "  --cache DIR       generated inputs, exact references, run outputs [build/bench-cache/scaling]\n"
    "  --exact-cache DIR exact maps of the 1024x512 inputs written by glint_bench_convolution,\n"
    "                    reused when present (<map>_<target>_<WxH>.exr) [build/bench-cache]\n"
    "  --out DIR         scaling.md and scaling.csv [tests/bench/results]\n"
    "  --images DIR      convolution_scaling.png [images]\n"
    "  --glint PATH      the glint binary [build/appliance/app/glint]\n"
    "  --threads N       --threads of glint convolve and of the exact references [2]\n"
    "  --quadrature-map NAME  map of the NN-upsampling quadrature check [courtyard]\n"
    "  --no-quadrature   skip that check\n"
    "  --keep-outputs    keep each run's output directory (<cache>/runs/<map>_<WxH>)\n"
    "  --whole-grids     glint convolve --no-fine-tiles (every finer grid whole, not in tiles);\n"
    "                    writes scaling_whole_grids.{md,csv} and convolution_scaling_whole_grids.png\n";

// ---------------------------------------------------------------- inputs

// Solid-angle-weighted f x f box average: each output texel is the mean radiance
// over the input texels it covers, weighted by their (row) solid angles.
HdrImage box_down(const HdrImage& in, int f) {
    const int w = in.width() / f, h = in.height() / f;
    const std::vector<double> omega = row_solid_angles(in.width(), in.height());
    HdrImage out(w, h);
    for (int jo = 0; jo < h; ++jo) {
        double wsum = 0;
        for (int dj = 0; dj < f; ++dj) wsum += omega[std::size_t(jo * f + dj)] * f;
        for (int io = 0; io < w; ++io) {
            double acc[3] = {0, 0, 0};
            for (int dj = 0; dj < f; ++dj) {
                const double wj = omega[std::size_t(jo * f + dj)];
                const float* p = in.row(jo * f + dj) + 3 * io * f;
                for (int di = 0; di < f; ++di)
                    for (int c = 0; c < 3; ++c) acc[c] += wj * p[3 * di + c];
            }
            out.set(io, jo, {float(acc[0] / wsum), float(acc[1] / wsum), float(acc[2] / wsum)});
        }
    }
    return out;
}

// Nearest-neighbour upsampling: each input texel becomes f x f equal texels.
HdrImage nn_up(const HdrImage& in, int f) {
    HdrImage out(in.width() * f, in.height() * f);
    for (int j = 0; j < out.height(); ++j) {
        const float* src = in.row(j / f);
        float* dst = out.row(j);
        for (int i = 0; i < out.width(); ++i)
            for (int c = 0; c < 3; ++c) dst[3 * i + c] = src[3 * (i / f) + c];
    }
    return out;
}

fs::path source_path(const Config& cfg, const std::string& map) { return cfg.worlds / (map + ".exr"); }

fs::path input_path(const Config& cfg, const std::string& map, Size s) {
    if (same(s, kSourceSize)) return source_path(cfg, map);
    return cfg.cache / "inputs" / (map + "_" + size_str(s) + ".exr");
}

HdrImage make_input(const HdrImage& source, Size s) {
    if (s.width < source.width()) return box_down(source, source.width() / s.width);
    if (s.width > source.width()) return nn_up(source, s.width / source.width());
    return source;
}

// The input file of a run, made (and cached) if it is not there yet.
fs::path ensure_input(const Config& cfg, const std::string& map, Size s) {
    const fs::path path = input_path(cfg, map, s);
    if (fs::exists(path)) return path;
    std::fprintf(stderr, "bench_scaling: making input %s\n", path.c_str());
    HdrImage source = load_exr(source_path(cfg, map)).image;
    fs::create_directories(path.parent_path());
    save_exr(path, make_input(source, s));
    return path;
}

// ---------------------------------------------------------------- exact references

struct Target {
    bool irradiance;
    double n;
    std::string label;  // as glint names the file: irradiance, phong_<n>
    Size size;          // reference size
};

std::string n_str(double n) {
    std::ostringstream s;
    s << n;
    return s.str();
}

Target make_target(bool irradiance, double n, Size size) {
    return {irradiance, n, irradiance ? "irradiance" : "phong_" + n_str(n), size};
}

std::vector<Target> whole_set() {
    std::vector<Target> t{make_target(true, 1, reference_size(1))};
    for (double n : glint::bench::whole_set_shininess()) t.push_back(make_target(false, n, reference_size(n)));
    return t;
}

std::string shininess_list() {
    std::string s;
    for (double n : glint::bench::whole_set_shininess()) s += (s.empty() ? "" : ",") + n_str(n);
    return s;
}

// Where the exact map of `t` computed from `map` at `source` size is cached.
// The 1024x512 maps first look in glint_bench_convolution's cache, same naming.
fs::path exact_path(const Config& cfg, const std::string& map, Size source, const Target& t, bool for_reading) {
    if (same(source, kSourceSize) && for_reading) {
        const fs::path shared = cfg.exact_cache / (map + "_" + t.label + "_" + size_str(t.size) + ".exr");
        if (fs::exists(shared)) return shared;
    }
    return cfg.cache / "exact" / (map + "_" + size_str(source) + "_" + t.label + "_" + size_str(t.size) + ".exr");
}

double read_seconds(const fs::path& exr) {
    std::ifstream in(exr.string() + ".seconds");
    double s = NAN;
    if (!(in >> s)) return NAN;
    return s;
}

struct ExactSet {
    std::vector<HdrImage> images;
    double seconds_computed = 0;  // this run's exact time (0: all cached)
};

// Exact maps of `targets` from `image` (the map `map` at size `source`), loaded
// from the cache where present, the others computed in one convolve() call.
ExactSet exact_set(const Config& cfg, const std::string& map, Size source, const HdrImage* image,
                   const std::vector<Target>& targets) {
    ExactSet out;
    out.images.resize(targets.size());
    std::vector<std::size_t> missing;
    for (std::size_t k = 0; k < targets.size(); ++k) {
        const fs::path p = exact_path(cfg, map, source, targets[k], true);
        if (fs::exists(p)) out.images[k] = load_exr(p).image;
        else missing.push_back(k);
    }
    if (missing.empty()) return out;
    HdrImage loaded;
    if (!image) {
        loaded = load_exr(input_path(cfg, map, source)).image;
        image = &loaded;
    }
    std::vector<MapRequest> requests;
    std::string labels;
    for (std::size_t k : missing) {
        const Target& t = targets[k];
        requests.push_back(t.irradiance ? MapRequest::make_irradiance() : MapRequest::make_phong(t.n, n_str(t.n)));
        requests.back().size = t.size;
        labels += " " + t.label;
    }
    std::fprintf(stderr, "bench_scaling: exact%s from %s %s (may take minutes)...\n", labels.c_str(), map.c_str(),
                 size_str(source).c_str());
    Options o;
    o.method = Method::Exact;
    o.threads = cfg.threads;
    const auto t0 = std::chrono::steady_clock::now();
    std::vector<MapResult> results = convolve(*image, requests, o);
    out.seconds_computed = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    for (std::size_t r = 0; r < missing.size(); ++r) {
        const std::size_t k = missing[r];
        const fs::path p = exact_path(cfg, map, source, targets[k], false);
        fs::create_directories(p.parent_path());
        save_exr(p, results[r].image);
        std::ofstream(p.string() + ".seconds") << results[r].seconds << '\n';
        out.images[k] = std::move(results[r].image);
    }
    return out;
}

// Multiply-adds of exact for `out` output texels of lobe n over `in` input texels:
// only the cap where the relative weight stays above the smallest normal double
// (cos >= exp(-708.39 / n)) is summed, the hemisphere for n <= 1.
double exact_cost(Size out, Size in, double n) {
    const double cap = n <= 1 ? 0.5 : 0.5 * (1 - std::exp(-708.39 / n));
    return texels(out) * texels(in) * cap;
}

// Over this many multiply-adds (~30 s on 2 cores) a reference is taken from a coarser
// NN-upsampled input.
constexpr double kReferenceBudget = 1.5e11;

// The input the reference of target `t` is summed from, for a run on `input`: the box-averaged
// input itself below 1024x512; from 1024x512 up, the finest NN-upsampled input up to the run's
// own whose exact sum fits kReferenceBudget. All of them are the same piecewise-constant radiance,
// so they differ only in the quadrature, which converges as the texel size squared: from the
// 1024x512 map alone the narrow lobes' references were off by up to 2.4 % weighted RMS (sunset,
// n = 20480, against the 2048x1024 quadrature), more than the maps they judged.
Size reference_source(Size input, const Target& t) {
    if (input.width <= kSourceSize.width) return input;
    Size s = input;
    while (s.width > kSourceSize.width && exact_cost(t.size, s, t.n) > kReferenceBudget) s = {s.width / 2, s.height / 2};
    return s;
}

// Exact maps of `targets` from `map`, target k summed from the input of size sources[k]: one
// exact_set call per source (the input made if needed and loaded once), cached.
std::vector<HdrImage> exact_by_source(const Config& cfg, const std::string& map, const std::vector<Size>& sources,
                                      const std::vector<Target>& targets) {
    std::vector<HdrImage> out(targets.size());
    std::map<int, std::vector<std::size_t>> by_source;  // source width -> targets
    for (std::size_t k = 0; k < targets.size(); ++k) by_source[sources[k].width].push_back(k);
    for (const auto& [width, index] : by_source) {
        std::vector<Target> ts;
        for (std::size_t k : index) ts.push_back(targets[k]);
        const Size source{width, width / 2};
        ensure_input(cfg, map, source);
        ExactSet set = exact_set(cfg, map, source, nullptr, ts);
        for (std::size_t i = 0; i < index.size(); ++i) out[index[i]] = std::move(set.images[i]);
    }
    return out;
}

// The whole set's references for a run on `input`, each from its reference_source.
std::vector<HdrImage> reference_set(const Config& cfg, const std::string& map, Size input,
                                    const std::vector<Target>& targets) {
    std::vector<Size> sources;
    for (const Target& t : targets) sources.push_back(reference_source(input, t));
    return exact_by_source(cfg, map, sources, targets);
}

// ---------------------------------------------------------------- running glint

struct ProcessOutcome {
    bool ok = false;
    std::string failure;
    double wall_seconds = NAN;
    double peak_mib = NAN;
};

ProcessOutcome run_process(std::vector<std::string> args, const fs::path& log) {
    ProcessOutcome out;
    const auto t0 = std::chrono::steady_clock::now();
    const pid_t pid = fork();
    if (pid < 0) {
        out.failure = std::string("fork failed: ") + std::strerror(errno);
        return out;
    }
    if (pid == 0) {
        std::vector<char*> argv;
        for (std::string& a : args) argv.push_back(a.data());
        argv.push_back(nullptr);
        const int fd = open(log.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
        if (fd >= 0) {
            dup2(fd, 1);
            dup2(fd, 2);
        }
        execv(argv[0], argv.data());
        std::fprintf(stderr, "exec %s failed: %s\n", argv[0], std::strerror(errno));
        _exit(127);
    }
    int status = 0;
    struct rusage usage {};
    while (wait4(pid, &status, 0, &usage) < 0)
        if (errno != EINTR) {
            out.failure = std::string("wait4 failed: ") + std::strerror(errno);
            return out;
        }
    out.wall_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    out.peak_mib = double(usage.ru_maxrss) / 1024.0;  // kilobytes on Linux
    if (WIFEXITED(status) && WEXITSTATUS(status) == 0) {
        out.ok = true;
    } else {
        out.failure = WIFEXITED(status) ? "exit code " + std::to_string(WEXITSTATUS(status))
                                        : "killed by signal " + std::to_string(WTERMSIG(status));
    }
    return out;
}

std::string tail_of(const fs::path& file, std::size_t lines) {
    std::ifstream in(file);
    std::vector<std::string> all;
    std::string line;
    while (std::getline(in, line)) all.push_back(line);
    std::string out;
    for (std::size_t k = all.size() > lines ? all.size() - lines : 0; k < all.size(); ++k) out += "    " + all[k] + "\n";
    return out;
}

struct MapRow {
    Target target;
    bool have = false;
    Size output{}, sum{};  // sum: the grid the sums ran on (report.json sum_size; 0x0 if not reported)
    bool over_tolerance = false;
    std::string method;
    int input_level = 0;
    double predicted = NAN, seconds = NAN;
    std::string shares_with;
    MapError error{NAN, NAN, NAN, NAN};
    // Exact on the candidate's own output grid, compared with the reference the
    // same way: the error of bilinear lookups on that grid alone (detail map only).
    MapError lookup_floor{NAN, NAN, NAN, NAN};
    std::string floor_note;  // why there is none
};

struct RunRow {
    Run run;
    bool ok = false;
    std::string failure;
    double load_s = NAN, load_mb_per_s = NAN, convolve_s = NAN, process_s = NAN, peak_mib = NAN;
    std::vector<MapRow> maps;
    double worst_rms = NAN, worst_texel = NAN;
    std::string worst_rms_map, worst_texel_map;
    std::vector<std::string> warnings;  // glint's own warnings (e.g. a plan predicted above tolerance)
};

double number_or_nan(const nlohmann::json& j, const char* key) {
    const auto it = j.find(key);
    return it != j.end() && it->is_number() ? it->get<double>() : NAN;
}

RunRow run_one(const Config& cfg, const Run& run, const std::vector<HdrImage>& reference,
               const std::vector<Target>& targets) {
    RunRow row;
    row.run = run;
    const fs::path input = ensure_input(cfg, run.map, run.input);
    const fs::path dir = cfg.cache / "runs" / (run.map + "_" + size_str(run.input));
    fs::remove_all(dir);
    fs::create_directories(dir);
    const fs::path log = cfg.cache / "runs" / (run.map + "_" + size_str(run.input) + ".log");
    // --allow-over-tolerance: a map predicted to miss the tolerance is written and
    // marked (over_tolerance in report.json) instead of failing the whole run.
    std::vector<std::string> args{cfg.glint,     "convolve",      input.string(), "--irradiance",
                                  "--shininess", shininess_list(), "--out",       dir.string(),
                                  "--threads",   std::to_string(cfg.threads), "--allow-over-tolerance"};
    if (cfg.whole_grids) args.push_back("--no-fine-tiles");
    const ProcessOutcome p = run_process(args, log);
    row.process_s = p.wall_seconds;
    row.peak_mib = p.peak_mib;
    if (!p.ok) {
        row.failure = "glint convolve " + input.string() + ": " + p.failure + " (log " + log.string() + ")";
        std::fprintf(stderr, "bench_scaling: %s; its last lines:\n%s", row.failure.c_str(), tail_of(log, 8).c_str());
        return row;
    }
    {
        std::ifstream in(log);
        std::string line;
        while (std::getline(in, line))
            if (line.find("warning") != std::string::npos) row.warnings.push_back(line);
    }
    nlohmann::json report;
    try {
        std::ifstream in(dir / "report.json");
        if (!in) throw std::runtime_error("cannot open");
        report = nlohmann::json::parse(in);
    } catch (const std::exception& e) {
        row.failure = "report " + (dir / "report.json").string() + " unreadable: " + e.what();
        std::fprintf(stderr, "bench_scaling: %s\n", row.failure.c_str());
        return row;
    }
    row.convolve_s = number_or_nan(report, "wall_seconds");
    row.load_s = number_or_nan(report, "load_seconds");
    row.load_mb_per_s = number_or_nan(report, "load_mb_per_s");
    row.maps.resize(targets.size());
    for (std::size_t k = 0; k < targets.size(); ++k) row.maps[k].target = targets[k];
    row.ok = true;
    for (const nlohmann::json& m : report.value("maps", nlohmann::json::array())) {
        const std::string label = m.value("map", std::string());
        const auto it = std::find_if(targets.begin(), targets.end(), [&](const Target& t) { return t.label == label; });
        if (it == targets.end()) continue;
        MapRow& r = row.maps[std::size_t(it - targets.begin())];
        r.have = true;
        r.method = m.value("method", std::string("?"));
        r.input_level = m.value("input_level", 0);
        r.predicted = number_or_nan(m, "predicted_error");
        r.seconds = number_or_nan(m, "wall_seconds");
        if (m.contains("shares_with") && m["shares_with"].is_string()) r.shares_with = m["shares_with"].get<std::string>();
        if (m.contains("output_size") && m["output_size"].is_array() && m["output_size"].size() == 2)
            r.output = {m["output_size"][0].get<int>(), m["output_size"][1].get<int>()};
        if (m.contains("sum_size") && m["sum_size"].is_array() && m["sum_size"].size() == 2)
            r.sum = {m["sum_size"][0].get<int>(), m["sum_size"][1].get<int>()};
        r.over_tolerance = m.contains("over_tolerance") && m["over_tolerance"].is_boolean() &&
                           m["over_tolerance"].get<bool>();
        const fs::path file = dir / m.value("file", label + ".exr");
        try {
            const HdrImage& ref = reference[std::size_t(it - targets.begin())];
            HdrImage map = load_exr(file).image;
            // With fine tiles, the map's whole finer grid (the tiles' texels there, its own
            // lookups elsewhere), as glint compare and glint render read it.
            const FineTiles fine = load_fine_tiles(m.contains("fine_tiles") ? m["fine_tiles"] : nlohmann::json(), dir,
                                                   map, (dir / "report.json").string() + ": " + label);
            if (!fine.empty()) {
                map = expand(map, fine);
                r.method += ", fine tiles";
                r.output = {map.width(), map.height()};
            }
            // A lobe map is the input's texels read through the lobe (docs/convolution.md, "The
            // lobe lookup"): its value at the reference's texel centres is that lookup's.
            const bool lobe = m.value("lookup", std::string("bilinear")) == "lobe";
            if (lobe) r.method += ", lobe lookup";
            r.error = compare_maps(map, ref, lobe ? MapLookup::Lobe : MapLookup::Bilinear, it->n);
        } catch (const std::exception& e) {
            row.ok = false;
            row.failure = e.what();
            std::fprintf(stderr, "bench_scaling: %s\n", e.what());
        }
    }
    for (const MapRow& r : row.maps) {
        if (!r.have) {
            row.ok = false;
            row.failure = "report.json has no map " + r.target.label;
            continue;
        }
        if (!(r.error.weighted_relative_rms <= row.worst_rms)) {
            row.worst_rms = r.error.weighted_relative_rms;
            row.worst_rms_map = r.target.label;
        }
        if (!(r.error.worst_texel <= row.worst_texel)) {
            row.worst_texel = r.error.worst_texel;
            row.worst_texel_map = r.target.label;
        }
    }
    if (!cfg.keep_outputs) fs::remove_all(dir);
    return row;
}

// Over this many multiply-adds (~10-20 s on 2 cores) the lookup floor is not computed.
constexpr double kFloorBudget = 6e10;

// The lookup floor of every map of `row` whose output grid is not the reference's.
void lookup_floors(const Config& cfg, RunRow& row, const std::vector<HdrImage>& reference) {
    std::vector<Target> ts;
    std::vector<Size> sources;
    std::vector<std::size_t> index;
    for (std::size_t k = 0; k < row.maps.size(); ++k) {
        MapRow& m = row.maps[k];
        if (!m.have || m.output.width == 0) continue;
        if (same(m.output, m.target.size)) {
            m.floor_note = "same grid";
            continue;
        }
        if (m.method.find("lobe lookup") != std::string::npos) {
            // Read through its lobe the map is the sum itself at any direction: no grid's
            // interpolation to measure (docs/convolution.md, "The lobe lookup").
            m.floor_note = "none (lobe lookup)";
            continue;
        }
        // From the reference's own source: the floor then holds no quadrature difference.
        const Size src = reference_source(row.run.input, m.target);
        Target t = m.target;
        t.size = m.output;
        if (exact_cost(t.size, src, t.n) > kFloorBudget) {
            m.floor_note = "not computed (exact too slow)";
            continue;
        }
        ts.push_back(t);
        sources.push_back(src);
        index.push_back(k);
    }
    const std::vector<HdrImage> floors = exact_by_source(cfg, row.run.map, sources, ts);
    for (std::size_t i = 0; i < ts.size(); ++i)
        row.maps[index[i]].lookup_floor = compare_maps(floors[i], reference[index[i]]);
}

// ---------------------------------------------------------------- quadrature check

struct QuadRow {
    Target target;
    MapError error{NAN, NAN, NAN, NAN};
    double seconds_1024 = NAN, seconds_2048 = NAN;
    bool done = false;
    std::string note;
};

// Exact from the 2048x1024 NN-upsampled map against exact from its 1024x512 source.
std::vector<QuadRow> quadrature_check(const Config& cfg) {
    const std::string& map = cfg.quadrature_map;
    std::vector<QuadRow> rows;
    const Size up{2048, 1024};
    HdrImage source = load_exr(source_path(cfg, map)).image;
    const fs::path up_path = ensure_input(cfg, map, up);
    HdrImage upsampled = load_exr(up_path).image;
    const std::vector<Target> cheap{make_target(true, 1, {128, 64}), make_target(false, 20, {128, 64}),
                                    make_target(false, 320, {128, 64})};
    const auto measure = [&](const std::vector<Target>& ts) {
        const ExactSet a = exact_set(cfg, map, kSourceSize, &source, ts);
        const ExactSet b = exact_set(cfg, map, up, &upsampled, ts);
        for (std::size_t k = 0; k < ts.size(); ++k) {
            QuadRow q;
            q.target = ts[k];
            q.error = compare_maps(b.images[k], a.images[k]);
            q.seconds_1024 = read_seconds(exact_path(cfg, map, kSourceSize, ts[k], true));
            q.seconds_2048 = read_seconds(exact_path(cfg, map, up, ts[k], false));
            q.done = true;
            rows.push_back(q);
        }
    };
    measure(cheap);
    // The narrow lobes (n = 5120 at 256x128 as asked; n = 5120 and 20480 at their
    // reference size 512x256, where the scaling table's errors are measured), each
    // only if exact on the 2048x1024 input is predicted to take under a minute:
    // 4x its time from the 1024x512 map (4x the input texels).
    for (const Target& narrow : {make_target(false, 5120, {256, 128}), make_target(false, 5120, {512, 256}),
                                 make_target(false, 20480, {512, 256})}) {
        if (!fs::exists(exact_path(cfg, map, up, narrow, false))) {
            exact_set(cfg, map, kSourceSize, &source, {narrow});
            const double t1 = read_seconds(exact_path(cfg, map, kSourceSize, narrow, true));
            if (std::isfinite(t1) && !(4 * t1 < 60)) {
                QuadRow q;
                q.target = narrow;
                q.seconds_1024 = t1;
                q.note = "skipped: exact from 2048x1024 predicted to take " + fmt("%.0f s", 4 * t1) + " (> 60 s)";
                rows.push_back(q);
                continue;
            }
        }
        measure({narrow});
    }
    return rows;
}

// ---------------------------------------------------------------- fits

struct Fit {
    double a = NAN, b = NAN;
    int points = 0;
};

// Least squares of log(t) = log(a) + b log(texels).
Fit fit_power(const std::vector<std::pair<double, double>>& xy) {
    Fit f;
    double sx = 0, sy = 0, sxx = 0, sxy = 0;
    for (const auto& [x, y] : xy) {
        if (!(x > 0 && y > 0)) continue;
        const double lx = std::log(x), ly = std::log(y);
        sx += lx;
        sy += ly;
        sxx += lx * lx;
        sxy += lx * ly;
        ++f.points;
    }
    if (f.points < 2) return f;
    const double n = f.points, den = n * sxx - sx * sx;
    if (!(std::fabs(den) > 1e-12)) return f;
    f.b = (n * sxy - sx * sy) / den;
    f.a = std::exp((sy - f.b * sx) / n);
    return f;
}

// A CSV field: empty when the value is missing (load times of an older glint).
std::string csv_number(double v) {
    if (!std::isfinite(v)) return "";
    std::ostringstream s;
    s << v;
    return s.str();
}

// The 1, 5 and 15 minute load averages: the machine may be shared.
std::string loadavg() {
    std::ifstream in("/proc/loadavg");
    double a = 0, b = 0, c = 0;
    if (!(in >> a >> b >> c)) return "unknown";
    return fmt("%.2f", a) + " " + fmt("%.2f", b) + " " + fmt("%.2f", c);
}

std::string na(const char* format, double v) { return std::isfinite(v) ? fmt(format, v) : std::string("n/a"); }

}  // namespace

int main(int argc, char** argv) {
    Config cfg;
    std::string preset = "full";
    std::vector<Run> explicit_runs;
    std::string command = "glint_bench_scaling";
    for (int i = 1; i < argc; ++i) command += std::string(" ") + argv[i];
    for (int i = 1; i < argc; ++i) {
        const std::string a = argv[i];
        auto value = [&](const char* flag) -> std::string {
            if (i + 1 >= argc) usage_error(std::string(flag) + " needs a value");
            return argv[++i];
        };
        if (a == "--help" || a == "-h") {
            std::fputs(kHelp, stdout);
            return 0;
        } else if (a == "--worlds") cfg.worlds = value("--worlds");
        else if (a == "--cache") cfg.cache = value("--cache");
        else if (a == "--exact-cache") cfg.exact_cache = value("--exact-cache");
        else if (a == "--out") cfg.out = value("--out");
        else if (a == "--images") cfg.images = value("--images");
        else if (a == "--glint") cfg.glint = value("--glint");
        else if (a == "--quadrature-map") cfg.quadrature_map = value("--quadrature-map");
        else if (a == "--no-quadrature") cfg.quadrature = false;
        else if (a == "--keep-outputs") cfg.keep_outputs = true;
        else if (a == "--whole-grids") cfg.whole_grids = true;
        else if (a == "--preset") {
            preset = value("--preset");
            if (preset != "full" && preset != "issue") usage_error("--preset takes full or issue, not " + preset);
        } else if (a == "--threads") {
            cfg.threads = std::atoi(value("--threads").c_str());
            if (cfg.threads < 1) usage_error("--threads takes a positive integer");
        } else if (a == "--run") {
            const std::string spec = value("--run");
            const auto colon = spec.find(':');
            if (colon == std::string::npos) usage_error("--run takes MAP:SIZES, got " + spec);
            const std::string map = spec.substr(0, colon);
            if (std::find(kMaps.begin(), kMaps.end(), map) == kMaps.end())
                usage_error("--run: unknown map " + map + " (courtyard, studio or sunset)");
            const std::string sizes = spec.substr(colon + 1);
            if (sizes == "all") {
                for (Size s : kSizes) explicit_runs.push_back({map, s});
            } else {
                for (const std::string& s : split(sizes, ',')) {
                    const std::optional<Size> size = parse_size(s);
                    if (!size) usage_error("--run: unknown input size " + s + " (256x128 ... 8192x4096)");
                    explicit_runs.push_back({map, *size});
                }
            }
        } else {
            usage_error("unknown argument " + a);
        }
    }
    if (!explicit_runs.empty()) {
        // In table order (map, then size), each once.
        const auto rank = [](const Run& r) {
            const auto m = std::find(kMaps.begin(), kMaps.end(), r.map) - kMaps.begin();
            return std::make_pair(m, r.input.width);
        };
        std::sort(explicit_runs.begin(), explicit_runs.end(),
                  [&](const Run& a, const Run& b) { return rank(a) < rank(b); });
        explicit_runs.erase(std::unique(explicit_runs.begin(), explicit_runs.end(),
                                        [&](const Run& a, const Run& b) { return rank(a) == rank(b); }),
                            explicit_runs.end());
        cfg.runs = explicit_runs;
    } else {
        for (const std::string& map : kMaps)
            for (Size s : kSizes)
                if (preset == "full" || map == "courtyard" || s.width == 1024 || s.width == 4096)
                    cfg.runs.push_back({map, s});
    }

    // Fail early, naming the file, on a missing input or glint binary.
    if (access(cfg.glint.c_str(), X_OK) != 0) {
        std::fprintf(stderr,
                     "bench_scaling: the glint binary %s is missing or not executable (build it with "
                     "./scripts/build.sh, or pass --glint PATH)\n",
                     cfg.glint.c_str());
        return 2;
    }
    std::vector<std::string> needed;
    for (const Run& r : cfg.runs) needed.push_back(r.map);
    if (cfg.quadrature) needed.push_back(cfg.quadrature_map);
    for (const std::string& map : needed)
        if (!fs::is_regular_file(source_path(cfg, map))) {
            std::fprintf(stderr, "bench_scaling: input %s does not exist (--worlds DIR)\n",
                         source_path(cfg, map).c_str());
            return 2;
        }

    try {
        fs::create_directories(cfg.cache);
        fs::create_directories(cfg.out);
        fs::create_directories(cfg.images);
        const auto start = std::chrono::steady_clock::now();
        const std::vector<Target> targets = whole_set();

        // Every input file first (cached), then the exact references per (map,
        // reference source size): nothing but glint runs while a run is timed.
        for (const Run& r : cfg.runs) ensure_input(cfg, r.map, r.input);
        const std::string loadavg_start = loadavg();
        // Exact references, per (map, reference source size), computed before any run.
        // Keyed by (map, run input width): each target's reference comes from its own source.
        std::map<std::pair<std::string, int>, std::vector<HdrImage>> references;
        for (const Run& r : cfg.runs) {
            const auto key = std::make_pair(r.map, r.input.width);
            if (references.count(key)) continue;
            references[key] = reference_set(cfg, r.map, r.input, targets);
        }

        std::vector<RunRow> rows;
        for (std::size_t k = 0; k < cfg.runs.size(); ++k) {
            const Run& r = cfg.runs[k];
            std::fprintf(stderr, "bench_scaling: [%zu/%zu] %s %s: glint convolve ...\n", k + 1, cfg.runs.size(),
                         r.map.c_str(), size_str(r.input).c_str());
            const auto& ref = references.at({r.map, r.input.width});
            rows.push_back(run_one(cfg, r, ref, targets));
            const RunRow& row = rows.back();
            if (row.ok)
                std::fprintf(stderr,
                             "bench_scaling: [%zu/%zu] %s %s: process %.2f s, convolve %.2f s, load %s s, peak %.0f "
                             "MiB, worst RMS %.2e (%s), worst texel %.2f %% (%s)\n",
                             k + 1, cfg.runs.size(), r.map.c_str(), size_str(r.input).c_str(), row.process_s,
                             row.convolve_s, na("%.2f", row.load_s).c_str(), row.peak_mib, row.worst_rms,
                             row.worst_rms_map.c_str(), 100 * row.worst_texel, row.worst_texel_map.c_str());
        }

        // The lookup floors of the detail map (the table per map below).
        std::vector<std::string> maps_run;
        for (const Run& r : cfg.runs)
            if (std::find(maps_run.begin(), maps_run.end(), r.map) == maps_run.end()) maps_run.push_back(r.map);
        const std::string detail_map =
            std::find(maps_run.begin(), maps_run.end(), "courtyard") != maps_run.end() ? "courtyard" : maps_run.front();
        for (RunRow& r : rows)
            if (r.run.map == detail_map && r.ok) {
                std::fprintf(stderr, "bench_scaling: lookup floors of %s %s\n", r.run.map.c_str(),
                             size_str(r.run.input).c_str());
                lookup_floors(cfg, r, references.at({r.run.map, r.run.input.width}));
            }

        std::vector<QuadRow> quad;
        if (cfg.quadrature) {
            std::fprintf(stderr, "bench_scaling: quadrature check on %s 2048x1024 (NN) against 1024x512\n",
                         cfg.quadrature_map.c_str());
            quad = quadrature_check(cfg);
        }
        const std::string loadavg_end = loadavg();
        const double total_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();

        // ---- csv ----
        std::ofstream csv(cfg.out / ("scaling" + cfg.suffix() + ".csv"));
        csv << "map,input_width,input_height,input_texels,load_s,load_mb_per_s,convolve_s,process_s,peak_mib,"
               "target,n,output_width,output_height,sum_width,sum_height,method,input_level,predicted_error,"
               "over_tolerance,map_seconds,weighted_rel_rms,worst_texel,lookup_floor_rms,lookup_floor_worst\n";
        for (const RunRow& r : rows) {
            if (r.maps.empty()) {
                csv << r.run.map << ',' << r.run.input.width << ',' << r.run.input.height << ','
                    << std::size_t(texels(r.run.input)) << ",,,," << r.process_s << ',' << r.peak_mib
                    << ",failed,,,,,,,,,,,,,,\n";
                continue;
            }
            for (const MapRow& m : r.maps)
                csv << r.run.map << ',' << r.run.input.width << ',' << r.run.input.height << ','
                    << std::size_t(texels(r.run.input)) << ',' << csv_number(r.load_s) << ','
                    << csv_number(r.load_mb_per_s) << ',' << r.convolve_s << ',' << r.process_s << ',' << r.peak_mib << ',' << m.target.label << ','
                    << m.target.n << ',' << m.output.width << ',' << m.output.height << ',' << m.sum.width << ','
                    << m.sum.height << ',' << m.method << ',' << m.input_level << ',' << m.predicted << ','
                    << (m.over_tolerance ? 1 : 0) << ',' << m.seconds << ','
                    << m.error.weighted_relative_rms << ',' << m.error.worst_texel << ','
                    << csv_number(m.lookup_floor.weighted_relative_rms) << ','
                    << csv_number(m.lookup_floor.worst_texel) << '\n';
        }

        // ---- md ----
        char date[64];
        const std::time_t now = std::time(nullptr);
        std::strftime(date, sizeof date, "%Y-%m-%d %H:%M UTC", std::gmtime(&now));
        std::ofstream md(cfg.out / ("scaling" + cfg.suffix() + ".md"));
        md << "# Convolution: scaling with the input size\n\n"
           << "Generated by `tests/bench/run_scaling_bench.sh` (`" << command << "`) on " << date << ", "
           << machine_description() << ", `glint convolve --threads " << cfg.threads << "`; the whole benchmark took "
           << fmt("%.0f s", total_s) << ". Load average (1/5/15 min, /proc/loadavg) " << loadavg_start
           << " before the runs, " << loadavg_end << " after: above " << cfg.threads
           << " the machine was shared and the times are inflated.\n\n"
           << "Each run is `glint convolve INPUT --irradiance --shininess " << shininess_list()
           << " --out DIR --threads " << cfg.threads
           << " --allow-over-tolerance` in its own process, without `--size` (the planner's own output sizes). "
              "*process* is the wall time of that process (EXR load, planning, convolution, writing 12 maps), "
              "*convolve* is report.json's `wall_seconds` (the `convolve()` call), *load* its `load_seconds` "
              "(n/a when glint does not report it), peak RSS is the child's `ru_maxrss` (wait4).\n\n"
           << "Inputs: blender-data `courtyard`, `studio`, `sunset` (1024x512) as they are; 256x128 and 512x256 by "
              "solid-angle-weighted 4x4 / 2x2 box averaging; 2048x1024, 4096x2048 and 8192x4096 by nearest-neighbour "
              "upsampling (each texel repeated 2x2, 4x4, 8x8).\n\n"
           << "Errors are against `exact` at the reference sizes (128x64 for irradiance and n <= 40, 256x128 for "
              "n <= 320, 512x256 above), the candidate resampled bilinearly to the reference's texel centres "
              "(`compare_maps`, docs/conventions.md). The reference of the 256x128, 512x256 and 1024x512 inputs "
              "is exact from that input itself. An NN-upsampled input is the same piecewise-constant radiance as "
              "its 1024x512 source, so any NN-upsampled version has the same integrals and differs only in the "
              "quadrature (which converges as the texel size squared): each target's reference for an upsampled "
              "input is exact from the finest NN-upsampled version up to the input itself whose exact sum stays "
              "under " << fmt("%.1e", kReferenceBudget) << " multiply-adds (about 30 s on 2 cores; an exact sum "
              "over an 8K input for every map would take hours). The sources used are listed under *Exact "
              "references*; the quadrature difference between two of them is measured below.\n\n";

        md << "## Per map and input size\n\n"
           << "Worst weighted relative RMS and worst texel over the 12 maps, with the map that was worst.\n\n";
        for (const std::string& map : maps_run) {
            md << "### " << map << "\n\n"
               << "| input | texels | load s | convolve s | process wall s | peak RSS MiB | worst weighted RMS | "
                  "worst texel |\n|---|---|---|---|---|---|---|---|\n";
            for (const RunRow& r : rows) {
                if (r.run.map != map) continue;
                md << "| " << size_str(r.run.input) << " | " << fmt("%.0f", texels(r.run.input)) << " | ";
                if (r.maps.empty()) {
                    md << "failed | | " << na("%.2f", r.process_s) << " | " << na("%.0f", r.peak_mib) << " | "
                       << r.failure << " | |\n";
                    continue;
                }
                md << na("%.2f", r.load_s)
                   << (std::isfinite(r.load_mb_per_s) ? " (" + fmt("%.0f", r.load_mb_per_s) + " MB/s)" : "") << " | " << na("%.2f", r.convolve_s) << " | " << na("%.2f", r.process_s)
                   << " | " << na("%.0f", r.peak_mib) << " | " << na("%.2e", r.worst_rms) << " (" << r.worst_rms_map
                   << ") | " << na("%.2f %%", 100 * r.worst_texel) << " (" << r.worst_texel_map << ") |\n";
            }
            md << '\n';
        }

        bool any_warning = false;
        for (const RunRow& r : rows) any_warning = any_warning || !r.warnings.empty();
        if (any_warning) {
            md << "Warnings printed by `glint convolve`:\n\n";
            for (const RunRow& r : rows)
                for (const std::string& w : r.warnings)
                    md << "- " << r.run.map << ' ' << size_str(r.run.input) << ": `" << w << "`\n";
            md << '\n';
        }

        md << "## Scaling exponent\n\n"
           << "Least-squares fit of `time = a * texels^b` on log-log, per map, over the inputs from 1024x512 up "
              "and over all sizes (points: number of input sizes in the fit).\n\n"
           << "| map | time | b (>= 1024x512) | a | points | b (all sizes) | a | points |\n"
           << "|---|---|---|---|---|---|---|---|\n";
        std::vector<std::pair<double, double>> pooled[2][2];
        for (const std::string& map : maps_run)
            for (int which = 0; which < 2; ++which) {
                std::vector<std::pair<double, double>> big, all;
                for (const RunRow& r : rows) {
                    if (r.run.map != map || !r.ok) continue;
                    const double t = which == 0 ? r.convolve_s : r.process_s;
                    all.push_back({texels(r.run.input), t});
                    pooled[which][1].push_back(all.back());
                    if (r.run.input.width >= kSourceSize.width) {
                        big.push_back(all.back());
                        pooled[which][0].push_back(all.back());
                    }
                }
                const Fit fb = fit_power(big), fa = fit_power(all);
                md << "| " << map << " | " << (which == 0 ? "convolve" : "process wall") << " | " << na("%.3f", fb.b)
                   << " | " << na("%.3g", fb.a) << " | " << fb.points << " | " << na("%.3f", fa.b) << " | "
                   << na("%.3g", fa.a) << " | " << fa.points << " |\n";
            }
        for (int which = 0; which < 2; ++which) {
            const Fit fb = fit_power(pooled[which][0]), fa = fit_power(pooled[which][1]);
            md << "| all maps pooled | " << (which == 0 ? "convolve" : "process wall") << " | " << na("%.3f", fb.b)
               << " | " << na("%.3g", fb.a) << " | " << fb.points << " | " << na("%.3f", fa.b) << " | "
               << na("%.3g", fa.a) << " | " << fa.points << " |\n";
        }
        md << "\nPlot: `" << (cfg.images / ("convolution_scaling" + cfg.suffix() + ".png")).string()
           << "` (log-log, convolve and process wall time against input texels, one line per map).\n\n";

        md << "## Quadrature difference of the NN-upsampling reference\n\n";
        if (quad.empty()) {
            md << "Not measured in this run (`--no-quadrature`).\n\n";
        } else {
            double worst_rms = 0, worst_texel = 0;
            for (const QuadRow& q : quad)
                if (q.done) {
                    worst_rms = std::max(worst_rms, q.error.weighted_relative_rms);
                    worst_texel = std::max(worst_texel, q.error.worst_texel);
                }
            md << "Exact from the 2048x1024 NN-upsampled " << cfg.quadrature_map << " against exact from its "
               << "1024x512 source, at the same output size. Both are sums over the same piecewise-constant "
                  "radiance; they differ only in the quadrature (one lobe sample per 1024x512 texel against four). "
                  "A reference summed from the 1024x512 map alone would not resolve errors of the upsampled "
                  "inputs below this level.\n\n"
               << "| target | size | weighted RMS | worst texel | exact s (1024x512) | exact s (2048x1024) |\n"
               << "|---|---|---|---|---|---|\n";
            for (const QuadRow& q : quad) {
                md << "| " << q.target.label << " | " << size_str(q.target.size) << " | ";
                if (q.done)
                    md << fmt("%.2e", q.error.weighted_relative_rms) << " | "
                       << fmt("%.3f %%", 100 * q.error.worst_texel);
                else
                    md << q.note << " |";
                md << " | " << na("%.1f", q.seconds_1024) << " | " << na("%.1f", q.seconds_2048) << " |\n";
            }
            md << "\nLargest: weighted RMS " << fmt("%.2e", worst_rms) << ", worst texel "
               << fmt("%.3f %%", 100 * worst_texel)
               << ". This is how far a reference from the 1024x512 map alone would be from the 2048x1024 "
                  "input's own exact maps (by 4/3 of it from the limit, if the difference falls as h^2), which "
                  "is why the narrow lobes' references of the upsampled inputs are summed from finer versions "
                  "(*Exact references*).\n\n";
        }

        md << "## " << detail_map << ": the planner's choice per map\n\n"
           << "*sum* is the grid the sums ran on (report.json `sum_size`), *predicted* the planner's predicted "
              "error (marked *over* where report.json says `over_tolerance`). *lookup floor* is `exact` "
              "computed on the map's own output grid (from the reference's source) and compared with the "
              "reference like the map itself: the error that bilinear lookups on that grid make by themselves, "
              "whatever the sums; the map's error minus it is the sums' share.\n\n"
           << "| input | target | reference | output | sum | method | level | predicted | map s | weighted RMS | "
              "worst texel | lookup floor RMS / worst |\n|---|---|---|---|---|---|---|---|---|---|---|---|\n";
        for (const RunRow& r : rows) {
            if (r.run.map != detail_map) continue;
            for (const MapRow& m : r.maps) {
                md << "| " << size_str(r.run.input) << " | " << m.target.label << " | " << size_str(m.target.size)
                   << " | " << size_str(m.output) << " | " << (m.sum.width ? size_str(m.sum) : "n/a") << " | "
                   << m.method << " | " << m.input_level << " | " << na("%.2g", m.predicted)
                   << (m.over_tolerance ? " over" : "") << " | " << na("%.3f", m.seconds)
                   << (m.shares_with.empty() ? "" : " (= " + m.shares_with + ")") << " | "
                   << na("%.2e", m.error.weighted_relative_rms) << " | " << na("%.2f %%", 100 * m.error.worst_texel)
                   << " | "
                   << (m.floor_note.empty() ? na("%.2e", m.lookup_floor.weighted_relative_rms) + " / " +
                                                  na("%.2f %%", 100 * m.lookup_floor.worst_texel)
                                            : m.floor_note)
                   << " |\n";
            }
        }
        md << '\n';

        md << "## Exact references\n\n"
           << "The input each target's reference is summed from, per run input (the same for every map).\n\n"
           << "| run input |";
        for (const Target& t : targets) md << ' ' << t.label << " |";
        md << "\n|---|";
        for (std::size_t k = 0; k < targets.size(); ++k) md << "---|";
        md << '\n';
        std::vector<int> widths_run;
        for (const Run& r : cfg.runs)
            if (std::find(widths_run.begin(), widths_run.end(), r.input.width) == widths_run.end())
                widths_run.push_back(r.input.width);
        std::sort(widths_run.begin(), widths_run.end());
        for (int w : widths_run) {
            md << "| " << size_str({w, w / 2}) << " |";
            for (const Target& t : targets) md << ' ' << size_str(reference_source({w, w / 2}, t)) << " |";
            md << '\n';
        }
        md << "\nPeak RSS of the benchmark program itself (inputs, references, comparisons): "
           << fmt("%.0f MiB", glint::bench::peak_rss_mib()) << ".\n";

        // ---- plot ----
        const fs::path dat = cfg.cache / ("scaling_plot" + cfg.suffix() + ".dat");
        {
            std::ofstream d(dat);
            for (const std::string& map : maps_run) {
                d << "# " << map << "\n";
                for (const RunRow& r : rows)
                    if (r.run.map == map && r.ok)
                        d << texels(r.run.input) << ' ' << r.convolve_s << ' ' << r.process_s << '\n';
                d << "\n\n";
            }
        }
        // The script without its terminal line: pngcairo draws the process-wall
        // lines dashed; plain png where cairo is missing.
        std::ostringstream g;
        g << "set output '" << (cfg.images / ("convolution_scaling" + cfg.suffix() + ".png")).string() << "'\n"
          << "set logscale xy\nset format x '10^{%L}'\nset format y '10^{%L}'\n"
          << "set xlabel 'input texels (256x128 ... 8192x4096)'\n"
          << "set ylabel 'wall time, whole set (irradiance + 11 reflection maps) [s], " << cfg.threads
          << " threads'\n"
          << "set title 'glint convolve: time against input size (" << date << ")'\n"
          << "set key top left box opaque\nset grid\n"
          << "plot ";
        const char* colours[] = {"#1f77b4", "#d62728", "#2ca02c"};
        for (std::size_t k = 0; k < maps_run.size(); ++k) {
            const std::string c = colours[k % 3];
            g << (k ? ", " : "") << "'" << dat.string() << "' index " << k
              << " using 1:2 with linespoints pt 7 lw 2 lc rgb '" << c << "' title '" << maps_run[k]
              << " convolve', '" << dat.string() << "' index " << k
              << " using 1:3 with linespoints pt 4 lw 2 dt 2 lc rgb '" << c << "' title '" << maps_run[k]
              << " process wall'";
        }
        g << '\n';
        const fs::path gp = cfg.cache / ("scaling_plot" + cfg.suffix() + ".gp");
        bool plotted = false;
        for (const char* terminal : {"pngcairo", "png"}) {
            std::ofstream(gp) << "set terminal " << terminal << " size 1000,650 font ',11'\n" << g.str();
            if (std::system(("gnuplot " + gp.string() + " 2>/dev/null").c_str()) == 0) {
                plotted = true;
                break;
            }
        }
        if (!plotted) std::fprintf(stderr, "bench_scaling: gnuplot failed; the plot was not written\n");
        std::fprintf(stderr, "bench_scaling: wrote %s, %s in %.0f s\n", (cfg.out / ("scaling" + cfg.suffix() + ".md")).c_str(),
                     (cfg.out / ("scaling" + cfg.suffix() + ".csv")).c_str(), total_s);
        for (const RunRow& r : rows)
            if (!r.ok) return 1;
        return 0;
    } catch (const std::exception& e) {
        std::fprintf(stderr, "bench_scaling: %s\n", e.what());
        return dynamic_cast<const InputError*>(&e) ? 2 : 1;
    }
}
