// Off-grid error of the planner's maps: what a renderer sees when it reads a
// convolved map by bilinear lookup at any direction (docs/conventions.md, "Maps of
// another size"), judged by exact_at (appliance/convolution/offgrid.hpp) at random
// directions, not by `exact` at the map's own texel centres.
//
// For each environment (courtyard, studio, sunset) the whole set is computed in one
// convolve() call with `auto`, the tolerance and NO fixed size: every map at the size
// its plan chose. Each map's off-grid weighted RMS and worst texel are measured, and,
// for the wide lobes, the same measure of the `exact` map at a fixed grid: the floor
// of bilinear lookup at that grid.
//
// Writes <out>/offgrid.csv and <out>/offgrid.md.
#include <algorithm>
#include <chrono>
#include <cstdint>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include "appliance/convolution/convolution.hpp"
#include "appliance/convolution/offgrid.hpp"
#include "appliance/core/errors.hpp"
#include "appliance/core/exr_io.hpp"
#include "appliance/core/memory.hpp"
#include "bench_util.hpp"

namespace fs = std::filesystem;
using namespace glint;
using namespace glint::convolution;
using glint::bench::fmt;

namespace {

const std::vector<std::string> kMaps{"courtyard", "studio", "sunset"};

struct Config {
    fs::path worlds = "/usr/share/blender/datafiles/studiolights/world";
    fs::path out = "tests/bench/results";
    std::vector<std::string> maps = kMaps;
    std::vector<std::string> targets;  // empty: the whole set
    int samples = 4096;
    std::uint64_t seed = 1;
    int threads = 2;
    double tolerance = 0.01;
    Size floor_size{256, 128};
    double floor_max_n = 40;  // the floor map is computed for n <= this (irradiance counts as 1)
};

struct Target {
    bool irradiance;
    double n;
    std::string label;
};

std::string n_text(double n) {
    std::ostringstream s;
    s << n;
    return s.str();
}

std::vector<Target> whole_set() {
    std::vector<Target> t{{true, 1, "irradiance"}};
    std::vector<double> ns = glint::bench::whole_set_shininess();
    ns.push_back(1e6);
    for (double n : ns) t.push_back({false, n, "phong_" + n_text(n)});
    return t;
}

MapRequest request_for(const Target& t) {
    return t.irradiance ? MapRequest::make_irradiance() : MapRequest::make_phong(t.n, n_text(t.n));
}

struct Row {
    std::string map, target;
    double n = 0;
    Size size;
    std::string method;
    double predicted = 0;
    OffGridError offgrid;
    double seconds = 0, judge_seconds = 0;
    std::optional<OffGridError> floor;
};

std::vector<std::string> split(const std::string& text) {
    std::vector<std::string> parts;
    std::stringstream s(text);
    std::string part;
    while (std::getline(s, part, ','))
        if (!part.empty()) parts.push_back(part);
    return parts;
}

[[noreturn]] void usage_error(const std::string& message) {
    std::fprintf(stderr, "glint_bench_offgrid: %s (see --help)\n", message.c_str());
    std::exit(2);
}

double seconds_since(std::chrono::steady_clock::time_point t0) {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

// theta, phi of a direction in degrees (docs/conventions.md), for the report.
// An error to 4 decimals, or in scientific notation below 1e-4 (the lobe lookup's are ~1e-8).
std::string small(double v) { return v > 0 && v < 1e-4 ? fmt("%.1e", v) : fmt("%.4f", v); }

std::string angles(const glm::dvec3& d) {
    const double theta = std::acos(std::max(-1.0, std::min(1.0, d.y))) * 180.0 / 3.14159265358979323846;
    const double phi = std::atan2(d.x, -d.z) * 180.0 / 3.14159265358979323846;
    char text[64];
    std::snprintf(text, sizeof text, "%.1f/%.1f", theta, phi);
    return text;
}

int run(const Config& cfg) {
    auto listed = [&](const std::string& name) {
        return std::find(cfg.targets.begin(), cfg.targets.end(), name) != cfg.targets.end();
    };
    std::vector<Target> targets;
    for (const Target& t : whole_set())
        if (cfg.targets.empty() || listed(t.label) || (!t.irradiance && listed(n_text(t.n))))
            targets.push_back(t);
    if (targets.empty()) usage_error("--targets selects none of the whole set");
    // Every file first: a missing one fails before minutes of work.
    for (const std::string& m : cfg.maps) {
        const fs::path path = cfg.worlds / (m + ".exr");
        if (!fs::exists(path)) {
            std::fprintf(stderr, "glint_bench_offgrid: environment map %s not found (--worlds %s)\n",
                         path.string().c_str(), cfg.worlds.string().c_str());
            return 2;
        }
    }
    fs::create_directories(cfg.out);

    std::vector<Row> rows;
    std::vector<std::pair<std::string, double>> whole_set_seconds;
    for (const std::string& m : cfg.maps) {
        const fs::path path = cfg.worlds / (m + ".exr");
        const HdrImage env = load_exr(path).image;
        std::vector<MapRequest> requests;
        for (const Target& t : targets) requests.push_back(request_for(t));
        Options o;
        o.method = Method::Auto;
        o.tolerance = cfg.tolerance;
        o.threads = cfg.threads;
        std::fprintf(stderr, "offgrid: %s %dx%d: auto, %zu maps, planner's sizes...\n", m.c_str(), env.width(),
                     env.height(), requests.size());
        const auto t0 = std::chrono::steady_clock::now();
        const std::vector<MapResult> results = convolve(env, requests, o);
        whole_set_seconds.push_back({m, seconds_since(t0)});

        // The floor: `exact` at a fixed grid for the wide lobes, one call.
        std::vector<MapRequest> floor_requests;
        std::vector<std::size_t> floor_of(targets.size(), SIZE_MAX);
        for (std::size_t k = 0; k < targets.size(); ++k)
            if (targets[k].n <= cfg.floor_max_n) {
                floor_of[k] = floor_requests.size();
                floor_requests.push_back(request_for(targets[k]));
                floor_requests.back().size = cfg.floor_size;
            }
        std::vector<MapResult> floors;
        if (!floor_requests.empty()) {
            std::fprintf(stderr, "offgrid: %s: exact at %dx%d for %zu maps (the floor of bilinear lookup)...\n",
                         m.c_str(), cfg.floor_size.width, cfg.floor_size.height, floor_requests.size());
            Options fo;
            fo.method = Method::Exact;
            fo.threads = cfg.threads;
            floors = convolve(env, floor_requests, fo);
        }

        for (std::size_t k = 0; k < targets.size(); ++k) {
            const MapResult& r = results[k];
            const double n = targets[k].n;
            Row row;
            row.map = m;
            row.target = targets[k].label;
            row.n = n;
            row.size = {r.image.width(), r.image.height()};
            row.method = to_string(r.plan.method);
            if (r.plan.lookup == MapLookup::Lobe) row.method += ", lobe lookup";
            row.predicted = r.plan.predicted_error;
            row.seconds = r.seconds;
            const auto t1 = std::chrono::steady_clock::now();
            row.offgrid = measure_offgrid_error(env, r.image, n, cfg.samples, cfg.seed, cfg.threads, r.plan.lookup);
            if (floor_of[k] != SIZE_MAX)
                row.floor = measure_offgrid_error(env, floors[floor_of[k]].image, n, cfg.samples, cfg.seed, cfg.threads);
            row.judge_seconds = seconds_since(t1);
            std::fprintf(stderr,
                         "offgrid: %s %-12s %4dx%-4d %-5s predicted %.4f  off-grid rms %.4f +- %.4f worst %.4f "
                         "(at %s)%s  convolve %.3f s, judge %.1f s\n",
                         m.c_str(), row.target.c_str(), row.size.width, row.size.height, row.method.c_str(),
                         row.predicted, row.offgrid.weighted_relative_rms, row.offgrid.rms_standard_error,
                         row.offgrid.worst_texel, angles(row.offgrid.worst_direction).c_str(),
                         row.floor ? (", floor rms " + fmt("%.4f", row.floor->weighted_relative_rms)).c_str() : "",
                         row.seconds, row.judge_seconds);
            rows.push_back(row);
        }
    }

    std::ofstream csv(cfg.out / "offgrid.csv");
    csv << "map,target,n,width,height,method,predicted_error,offgrid_rms,offgrid_rms_se,offgrid_worst,"
           "worst_theta_phi_deg,seconds,floor_width,floor_height,floor_rms,floor_rms_se,floor_worst\n";
    for (const Row& r : rows) {
        csv << r.map << ',' << r.target << ',' << r.n << ',' << r.size.width << ',' << r.size.height << ','
            << r.method << ',' << r.predicted << ',' << r.offgrid.weighted_relative_rms << ','
            << r.offgrid.rms_standard_error << ',' << r.offgrid.worst_texel << ','
            << angles(r.offgrid.worst_direction) << ',' << r.seconds << ',';
        if (r.floor)
            csv << cfg.floor_size.width << ',' << cfg.floor_size.height << ',' << r.floor->weighted_relative_rms << ','
                << r.floor->rms_standard_error << ',' << r.floor->worst_texel << '\n';
        else
            csv << ",,,,\n";
    }

    char date[64];
    const std::time_t now = std::time(nullptr);
    std::strftime(date, sizeof date, "%Y-%m-%d %H:%M UTC", std::gmtime(&now));
    std::ofstream md(cfg.out / "offgrid.md");
    md << "# Off-grid error of the planner's maps\n\n"
       << "Generated by `tests/bench/run_offgrid_bench.sh` on " << date << ", "
       << glint::bench::machine_description() << ", " << cfg.threads << " threads.\n\n"
       << "Each environment's whole set is one `convolve()` call with `auto`, tolerance " << cfg.tolerance
       << " and no fixed size, so every map has the output size its plan chose. A renderer reads a map by "
       << "bilinear lookup at any direction (a map marked *lobe lookup*, whose lobe is narrower than half the "
       << "input's texels, holds the input's texels and is read through the lobe: `sample_lobe`, "
       << "docs/convolution.md); the error here is that lookup against the conventions' sum "
       << "`E^n(r)` over every input texel at the same direction (`exact_at`, "
       << "appliance/convolution/offgrid.hpp), at " << cfg.samples << " random directions (seed " << cfg.seed
       << "): half uniform on the sphere, half drawn from the map in proportion to dOmega |value|^2, "
       << "weighted by the mixture density. *rms* is the solid-angle-weighted relative RMS (± its standard "
       << "error), *worst* the largest |A-B| / max(|B|, mean|B|) over the samples and channels, at the "
       << "direction theta/phi in degrees. *predicted* is the plan's predicted error (against `exact` at "
       << "the map's own texels). *floor* is the same measure of the `exact` map at " << cfg.floor_size.width
       << "x" << cfg.floor_size.height << " (for n <= " << cfg.floor_max_n
       << "): the error of bilinear lookup itself at that grid. Maps whose off-grid rms exceeds the "
       << "tolerance are marked **over**.\n\n";
    md << "| map | target | output | method | predicted | off-grid rms | worst | worst at | seconds | floor rms | "
          "floor worst |\n|---|---|---|---|---|---|---|---|---|---|---|\n";
    for (const Row& r : rows) {
        const bool over = r.offgrid.weighted_relative_rms > cfg.tolerance;
        md << "| " << r.map << " | " << r.target << " | " << r.size.width << "x" << r.size.height << " | "
           << r.method << " | " << fmt("%.4f", r.predicted) << " | " << (over ? "**" : "")
           << small(r.offgrid.weighted_relative_rms) << (over ? " over**" : "") << " ± "
           << small(r.offgrid.rms_standard_error) << " | " << small(r.offgrid.worst_texel) << " | "
           << angles(r.offgrid.worst_direction) << " | " << fmt("%.3f", r.seconds) << " | "
           << (r.floor ? fmt("%.4f", r.floor->weighted_relative_rms) : "") << " | "
           << (r.floor ? fmt("%.4f", r.floor->worst_texel) : "") << " |\n";
    }
    md << "\nWhole set (one `convolve()` call): ";
    for (std::size_t k = 0; k < whole_set_seconds.size(); ++k)
        md << (k ? ", " : "") << whole_set_seconds[k].first << " " << fmt("%.3f s", whole_set_seconds[k].second);
    md << ".\n";
    std::fprintf(stderr, "offgrid: wrote %s and %s\n", (cfg.out / "offgrid.md").string().c_str(),
                 (cfg.out / "offgrid.csv").string().c_str());
    return 0;
}

}  // namespace

int main(int argc, char** argv) {
    glint::keep_freed_memory();  // as glint's own main does
    Config cfg;
    for (int i = 1; i < argc; ++i) {
        const std::string a = argv[i];
        auto value = [&]() -> std::string {
            if (i + 1 >= argc) usage_error(a + " needs a value");
            return argv[++i];
        };
        auto number = [&](const std::string& text) {
            char* end = nullptr;
            const double v = std::strtod(text.c_str(), &end);
            if (text.empty() || *end != '\0' || !std::isfinite(v)) usage_error(a + " needs a number, got '" + text + "'");
            return v;
        };
        if (a == "--help" || a == "-h") {
            std::printf(
                "glint_bench_offgrid [--worlds DIR] [--out DIR] [--maps LIST] [--targets LIST] [--samples N]\n"
                "                    [--seed N] [--threads N] [--tolerance T] [--floor-size WxH] [--floor-max-n N]\n"
                "Off-grid error of the auto planner's maps (its own output sizes): bilinear lookup at random\n"
                "directions against the conventions' sum over every input texel (exact_at).\n"
                "  --worlds DIR      blender studio lights (default %s)\n"
                "  --out DIR         where offgrid.md and offgrid.csv go (default %s)\n"
                "  --maps LIST       comma list of courtyard,studio,sunset (default all three)\n"
                "  --targets LIST    comma list of irradiance and n values, e.g. irradiance,1,5120\n"
                "                    (default the whole set: irradiance, n = 1 ... 20480, 1e6)\n"
                "  --samples N       directions per map (default %d)\n"
                "  --seed N          random seed (default %llu)\n"
                "  --threads N       threads for convolve and the judge (default %d)\n"
                "  --tolerance T     auto's tolerance (default %g)\n"
                "  --floor-size WxH  grid of the exact map measured as the floor (default %dx%d)\n"
                "  --floor-max-n N   largest n with a floor map (default %g; -1: none)\n",
                cfg.worlds.string().c_str(), cfg.out.string().c_str(), cfg.samples,
                (unsigned long long)cfg.seed, cfg.threads, cfg.tolerance, cfg.floor_size.width,
                cfg.floor_size.height, cfg.floor_max_n);
            return 0;
        } else if (a == "--worlds") cfg.worlds = value();
        else if (a == "--out") cfg.out = value();
        else if (a == "--maps") {
            cfg.maps = split(value());
            for (const std::string& m : cfg.maps)
                if (std::find(kMaps.begin(), kMaps.end(), m) == kMaps.end())
                    usage_error("--maps takes courtyard, studio, sunset; got '" + m + "'");
        } else if (a == "--targets") cfg.targets = split(value());
        else if (a == "--samples") cfg.samples = int(number(value()));
        else if (a == "--seed") cfg.seed = std::uint64_t(number(value()));
        else if (a == "--threads") cfg.threads = int(number(value()));
        else if (a == "--tolerance") cfg.tolerance = number(value());
        else if (a == "--floor-max-n") cfg.floor_max_n = number(value());
        else if (a == "--floor-size") {
            const std::string v = value();
            int w = 0, h = 0;
            char x = 0;
            if (std::sscanf(v.c_str(), "%d%c%d", &w, &x, &h) != 3 || x != 'x' || w < 1 || h < 1)
                usage_error("--floor-size needs WxH, got '" + v + "'");
            cfg.floor_size = {w, h};
        } else usage_error("unknown option '" + a + "'");
    }
    if (cfg.samples < 1) usage_error("--samples must be >= 1");
    if (cfg.threads < 1) usage_error("--threads must be >= 1");
    try {
        return run(cfg);
    } catch (const InputError& e) {
        std::fprintf(stderr, "glint_bench_offgrid: %s\n", e.what());
        return 2;
    } catch (const std::exception& e) {
        std::fprintf(stderr, "glint_bench_offgrid: %s\n", e.what());
        return 1;
    }
}
