// Speed against error of every convolution method (docs/convolution.md). For
// each map and each target (irradiance, n in the list) at the reference size,
// every method runs once as a Google Benchmark with manual time; its error is
// measured against `exact` at the same size.
//
// Exact reference images are cached (they take minutes); the exact whole set
// of one map (--timing-map) is recomputed in every run so that the headline
// ratio auto : exact is measured in one run on one machine.
//
// Writes <out>/convolution.csv, <out>/convolution.md and, with gnuplot, the plot
// <images>/convolution_speed_error.png.
#include <benchmark/benchmark.h>
#include <sys/resource.h>
#include <fcntl.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "appliance/core/memory.hpp"
#include "bench_util.hpp"
#include "appliance/convolution/convolution.hpp"
#include "appliance/core/equirect.hpp"
#include "appliance/core/error_metrics.hpp"
#include "appliance/core/exr_io.hpp"

namespace fs = std::filesystem;
using namespace glint;
using namespace glint::convolution;

using glint::bench::fmt;
using glint::bench::machine_description;
using glint::bench::reference_size;

namespace {

struct Config {
    fs::path worlds = "/usr/share/blender/datafiles/studiolights/world";
    fs::path cache = "build/bench-cache";
    fs::path out = "tests/bench/results";
    fs::path images = "images";
    std::string timing_map = "courtyard";
    std::string glint = "build/appliance/app/glint";
    int threads = 2;
    bool quick = false;  // fewer targets, for a smoke run
};

struct Target {
    bool irradiance;
    double n;
    std::string label;
    Size size;
};

std::vector<Target> targets(bool quick) {
    std::vector<Target> t;
    t.push_back({true, 1, "irradiance", reference_size(1)});
    const std::vector<double> ns = quick ? std::vector<double>{1, 40, 640, 20480} : glint::bench::whole_set_shininess();
    for (double n : ns) {
        std::ostringstream label;
        label << "phong_" << n;
        t.push_back({false, n, label.str(), reference_size(n)});
    }
    return t;
}

struct EnvMap {
    std::string name;
    HdrImage image;
};

// The hard case of a small sun at benchmark scale: one texel of 1e5 on a 1e-2
// background, at a direction that is neither a pole nor the seam.
HdrImage synthetic_sun() {
    HdrImage im(1024, 512);
    for (float& v : im.data()) v = 0.01f;
    im.set(700, 150, {1e5f, 1e5f, 1e5f});
    return im;
}

struct Row {
    std::string map, target, method, param;
    double n = 0;
    Size size;
    double seconds = 0;
    MapError error;
};

std::vector<MapRequest> requests_for(const std::vector<Target>& ts) {
    std::vector<MapRequest> r;
    for (const Target& t : ts) {
        if (t.irradiance) {
            r.push_back(MapRequest::make_irradiance());
        } else {
            std::ostringstream s;
            s << t.n;
            r.push_back(MapRequest::make_phong(t.n, s.str()));
        }
    }
    return r;
}

fs::path cache_path(const Config& cfg, const std::string& map, const Target& t) {
    return cfg.cache / (map + "_" + t.label + "_" + std::to_string(t.size.width) + "x" +
                        std::to_string(t.size.height) + ".exr");
}

// Runs of each fast method per map; the median is reported.
constexpr int kRepetitions = 5;

struct RunOutcome {
    std::vector<MapResult> results;
    double seconds = 0;  // wall time of the convolve() calls, including shared set-up
};

RunOutcome run_method(const HdrImage& env, const std::vector<Target>& ts, Method method, int sh_order,
                      int threads) {
    // One convolve() call for the whole set, each map at its reference size,
    // as the appliance asks for all of its maps at once.
    std::vector<MapRequest> requests = requests_for(ts);
    for (std::size_t k = 0; k < ts.size(); ++k) requests[k].size = ts[k].size;
    Options o;
    o.method = method;
    o.sh_order = sh_order;
    o.threads = threads;
    RunOutcome out;
    const auto t0 = std::chrono::steady_clock::now();
    out.results = convolve(env, requests, o);
    out.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    return out;
}

// Peak resident memory (MiB) of `glint convolve` in its own process, running
// the auto plan of the whole set on `input` with every map at `size` (the CLI
// fixes one size for all maps; at the largest reference size this bounds the
// whole set at its reference sizes from above).
double glint_peak_mib(const std::string& glint, const fs::path& input, const std::vector<Target>& group,
                      Size size, const fs::path& out_dir, int threads) {
    std::vector<std::string> args{glint, "convolve", input.string(), "--out", out_dir.string(), "--size",
                                  std::to_string(size.width) + "x" + std::to_string(size.height),
                                  "--threads", std::to_string(threads)};
    std::string shininess;
    for (const Target& t : group) {
        if (t.irradiance) {
            args.push_back("--irradiance");
            continue;
        }
        std::ostringstream n;
        n << t.n;
        shininess += (shininess.empty() ? "" : ",") + n.str();
    }
    if (!shininess.empty()) {
        args.push_back("--shininess");
        args.push_back(shininess);
    }
    const pid_t pid = fork();
    if (pid == 0) {
        std::vector<char*> argv;
        for (std::string& a : args) argv.push_back(a.data());
        argv.push_back(nullptr);
        const int devnull = open("/dev/null", O_WRONLY);
        dup2(devnull, 1);
        dup2(devnull, 2);
        execv(argv[0], argv.data());
        _exit(127);
    }
    int status = 0;
    struct rusage usage {};
    wait4(pid, &status, 0, &usage);
    if (!WIFEXITED(status) || WEXITSTATUS(status) != 0) return NAN;
    return double(usage.ru_maxrss) / 1024.0;
}


}  // namespace

int main(int argc, char** argv) {
    glint::keep_freed_memory();  // as glint's own main does
    Config cfg;
    std::vector<char*> bench_args{argv[0]};
    for (int i = 1; i < argc; ++i) {
        const std::string a = argv[i];
        auto value = [&](const char* flag) -> std::string {
            if (i + 1 >= argc) {
                std::fprintf(stderr, "bench: %s needs a value\n", flag);
                std::exit(2);
            }
            return argv[++i];
        };
        if (a == "--help") {
            std::printf(
                "glint_bench_convolution [--worlds DIR] [--cache DIR] [--out DIR] [--images DIR]\n"
                "                        [--timing-map NAME] [--glint PATH] [--threads N] [--quick]\n"
                "                        [google benchmark flags]\n"
                "Speed against error of exact, auto, cone, sh (orders 35/64/128) and mipmap on\n"
                "courtyard, studio, sunset (blender-data) and a synthetic sun map.\n");
            return 0;
        } else if (a == "--worlds") cfg.worlds = value("--worlds");
        else if (a == "--cache") cfg.cache = value("--cache");
        else if (a == "--out") cfg.out = value("--out");
        else if (a == "--images") cfg.images = value("--images");
        else if (a == "--timing-map") cfg.timing_map = value("--timing-map");
        else if (a == "--glint") cfg.glint = value("--glint");
        else if (a == "--threads") cfg.threads = std::atoi(value("--threads").c_str());
        else if (a == "--quick") cfg.quick = true;
        else bench_args.push_back(argv[i]);
    }
    int bargc = int(bench_args.size());
    benchmark::Initialize(&bargc, bench_args.data());
    fs::create_directories(cfg.cache);
    fs::create_directories(cfg.out);
    fs::create_directories(cfg.images);

    std::vector<EnvMap> maps;
    for (const char* name : {"courtyard", "studio", "sunset"})
        maps.push_back({name, load_exr(cfg.worlds / (std::string(name) + ".exr")).image});
    maps.push_back({"sun", synthetic_sun()});
    const std::vector<Target> ts = targets(cfg.quick);

    std::vector<Row> rows;
    std::map<std::string, double> exact_whole_set_seconds, auto_whole_set_seconds;
    // Whole-set wall time per (variant label, map), including shared set-up.
    std::map<std::pair<std::string, std::string>, double> whole_set_seconds;
    std::map<std::string, std::vector<HdrImage>> references;

    struct Variant {
        Method method;
        int sh_order;
        std::string name, param;
    };
    const std::vector<Variant> variants{{Method::Auto, 0, "auto", ""},
                                        {Method::Cone, 0, "cone", ""},
                                        {Method::Sh, 35, "sh", "35"},
                                        {Method::Sh, 64, "sh", "64"},
                                        {Method::Sh, 128, "sh", "128"},
                                        {Method::Mipmap, 0, "mipmap", ""}};

    // Every benchmark is registered first and run in one RunSpecifiedBenchmarks
    // call, in registration order: the exact references before the methods
    // that are compared against them.
    for (const EnvMap& m : maps) {
        const bool timed = m.name == cfg.timing_map;
        bool cached = !timed;
        for (const Target& t : ts) cached = cached && fs::exists(cache_path(cfg, m.name, t));
        if (cached) {
            for (const Target& t : ts) references[m.name].push_back(load_exr(cache_path(cfg, m.name, t)).image);
            continue;
        }
        benchmark::RegisterBenchmark(("exact/" + m.name).c_str(), [&, timed](benchmark::State& st) {
            for (auto _ : st) {
                std::fprintf(stderr, "bench: exact whole set of %s (minutes)...\n", m.name.c_str());
                const RunOutcome exact = run_method(m.image, ts, Method::Exact, 0, cfg.threads);
                st.SetIterationTime(exact.seconds);
                if (timed) exact_whole_set_seconds[m.name] = exact.seconds;
                whole_set_seconds[{"exact", m.name}] = exact.seconds;
                references[m.name].clear();
                for (std::size_t k = 0; k < ts.size(); ++k) {
                    save_exr(cache_path(cfg, m.name, ts[k]), exact.results[k].image);
                    references[m.name].push_back(exact.results[k].image);
                    rows.push_back({m.name, ts[k].label, "exact", "", ts[k].n, ts[k].size,
                                    exact.results[k].seconds, {}});
                }
            }
        })->Iterations(1)->UseManualTime()->Unit(benchmark::kSecond);
    }
    for (const EnvMap& m : maps) {
        for (const Variant& v : variants) {
            const std::string name = v.name + (v.param.empty() ? "" : "_" + v.param) + "/" + m.name;
            benchmark::RegisterBenchmark(name.c_str(), [&, v](benchmark::State& st) {
                for (auto _ : st) {
                    // The median of kRepetitions runs: one run of a 50 ms job on a
                    // shared machine is at the mercy of the scheduler, and the first
                    // also pays one-time costs (worker threads, heap growth) that a
                    // long-running appliance pays once. exact runs once (16 s).
                    std::vector<RunOutcome> runs;
                    for (int r = 0; r < kRepetitions; ++r)
                        runs.push_back(run_method(m.image, ts, v.method, v.sh_order, cfg.threads));
                    std::sort(runs.begin(), runs.end(),
                              [](const RunOutcome& a, const RunOutcome& b) { return a.seconds < b.seconds; });
                    const RunOutcome& run = runs[runs.size() / 2];
                    // A filter that left out the exact run: the references from the cache.
                    if (references[m.name].size() != ts.size()) {
                        references[m.name].clear();
                        for (const Target& t : ts) {
                            if (!fs::exists(cache_path(cfg, m.name, t)))
                                throw std::runtime_error("no exact reference " + cache_path(cfg, m.name, t).string() +
                                                         ": run exact/" + m.name + " too");
                            references[m.name].push_back(load_exr(cache_path(cfg, m.name, t)).image);
                        }
                    }
                    st.SetIterationTime(run.seconds);
                    if (v.method == Method::Auto) auto_whole_set_seconds[m.name] = run.seconds;
                    whole_set_seconds[{v.name + v.param, m.name}] = run.seconds;
                    for (std::size_t k = 0; k < ts.size(); ++k)
                        rows.push_back({m.name, ts[k].label, v.name, v.param, ts[k].n, ts[k].size,
                                        run.results[k].seconds,
                                        compare_maps(run.results[k].image, references[m.name][k])});
                }
            })->Iterations(1)->UseManualTime()->Unit(benchmark::kMillisecond);
        }
    }
    benchmark::RunSpecifiedBenchmarks();
    // Listing the benchmarks, or running only some of them: no tables are written over the
    // committed ones.
    bool partial = false;
    for (const char* arg : bench_args)
        if (std::string(arg).rfind("--benchmark_list_tests", 0) == 0 || std::string(arg).rfind("--benchmark_filter", 0) == 0)
            partial = true;
    if (partial) {
        std::fprintf(stderr, "bench: a partial run (--benchmark_filter or _list_tests); no tables written\n");
        return 0;
    }

    // Peak memory of the auto whole set, run by the real `glint convolve` in its
    // own process on the timing map, every map at the largest reference size.
    Size largest{0, 0};
    for (const Target& t : ts)
        if (t.size.width > largest.width) largest = t.size;
    const double auto_peak_mib = glint_peak_mib(cfg.glint, cfg.worlds / (cfg.timing_map + ".exr"), ts, largest,
                                                cfg.cache / "peak", cfg.threads);

    // ---- tables ----
    std::ofstream csv(cfg.out / "convolution.csv");
    csv << "map,target,n,width,height,method,param,seconds,weighted_rel_rms,worst_texel,mean_abs_pct,max_abs_pct\n";
    for (const Row& r : rows)
        csv << r.map << ',' << r.target << ',' << r.n << ',' << r.size.width << ',' << r.size.height << ','
            << r.method << ',' << r.param << ',' << r.seconds << ',' << r.error.weighted_relative_rms << ','
            << r.error.worst_texel << ',' << r.error.mean_abs_percent << ',' << r.error.max_abs_percent << '\n';

    char date[64];
    const std::time_t now = std::time(nullptr);
    std::strftime(date, sizeof date, "%Y-%m-%d %H:%M UTC", std::gmtime(&now));
    std::ofstream md(cfg.out / "convolution.md");
    md << "# Convolution: speed against error\n\n"
       << "Generated by `tests/bench/run_convolution_bench.sh` on " << date << ", " << machine_description()
       << ", " << cfg.threads << " threads. Errors are against `exact` at the reference size "
       << "(128x64 for n <= 40, 256x128 for n <= 320, 512x256 above); weighted relative RMS and worst texel "
       << "per docs/conventions.md, mean/max absolute percentage as thesis eq. 6.1/6.2. Each method "
       << "computes the whole set in one `convolve()` call, each map at its reference size; times of the "
       << "fast methods are the median of " << kRepetitions << " runs, exact runs once.\n\n";
    const double exact_s = exact_whole_set_seconds.count(cfg.timing_map) ? exact_whole_set_seconds[cfg.timing_map] : NAN;
    const double auto_s = auto_whole_set_seconds[cfg.timing_map];
    md << "## Headline (" << cfg.timing_map << ", whole set: irradiance + " << ts.size() - 1
       << " shininess values, reference sizes)\n\n"
       << "| | wall time | ratio |\n|---|---|---|\n"
       << "| exact | " << fmt("%.2f s", exact_s) << " | 1 |\n"
       << "| auto (tau = 1 %) | " << fmt("%.3f s", auto_s) << " | " << fmt("%.0fx faster", exact_s / auto_s) << " |\n\n"
       << "Peak resident memory of the auto whole set (`glint convolve`, every map at the largest reference "
          "size, an upper bound; including EXR load and save): "
       << fmt("%.0f MiB", auto_peak_mib) << ".\n\n";

    // Whole set per method and map: time against the worst map's error.
    struct Summary {
        double seconds = 0, worst_rms = 0, worst_max_pct = 0;
        bool have = false;
    };
    const auto summarise = [&](const std::string& method, const std::string& param, const std::string& map) {
        Summary sm;
        const auto it = whole_set_seconds.find({method + param, map});
        if (it == whole_set_seconds.end()) return sm;
        sm.have = true;
        sm.seconds = it->second;
        for (const Row& r : rows)
            if (r.map == map && r.method == method && r.param == param) {
                sm.worst_rms = std::max(sm.worst_rms, r.error.weighted_relative_rms);
                sm.worst_max_pct = std::max(sm.worst_max_pct, r.error.max_abs_percent);
            }
        return sm;
    };
    md << "## Whole set per method (time; worst weighted relative RMS / worst max abs % over the " << ts.size()
       << " maps)\n\n| method |";
    for (const EnvMap& m : maps) md << ' ' << m.name << " |";
    md << "\n|---|";
    for (std::size_t k = 0; k < maps.size(); ++k) md << "---|";
    md << "\n| exact |";
    for (const EnvMap& m : maps) {
        const Summary sm = summarise("exact", "", m.name);
        md << ' ' << (sm.have ? fmt("%.2f s", sm.seconds) : std::string("cached")) << " |";
    }
    md << '\n';
    for (const Variant& v : variants) {
        md << "| " << v.name << (v.param.empty() ? "" : " " + v.param) << " |";
        for (const EnvMap& m : maps) {
            const Summary sm = summarise(v.name, v.param, m.name);
            md << ' ' << fmt("%.3f s", sm.seconds) << "; " << fmt("%.1e", sm.worst_rms) << " / "
               << fmt("%.2f %%", sm.worst_max_pct) << " |";
        }
        md << '\n';
    }
    md << "\nExact whole sets marked `cached` were computed in an earlier run; the headline ratio uses the map "
          "timed in this run.\n\n";

    for (const Variant& v : variants) {
        md << "## " << v.name << (v.param.empty() ? "" : " order " + v.param) << "\n\n"
           << "| target | size |";
        for (const EnvMap& m : maps) md << ' ' << m.name << " time | rel RMS | mean % | max % |";
        md << "\n|---|---|";
        for (std::size_t k = 0; k < maps.size(); ++k) md << "---|---|---|---|";
        md << '\n';
        for (const Target& t : ts) {
            md << "| " << t.label << " | " << t.size.width << 'x' << t.size.height << " |";
            for (const EnvMap& m : maps)
                for (const Row& r : rows)
                    if (r.map == m.name && r.target == t.label && r.method == v.name && r.param == v.param)
                        md << ' ' << fmt("%.4f s", r.seconds) << " | " << fmt("%.2e", r.error.weighted_relative_rms)
                           << " | " << fmt("%.3f", r.error.mean_abs_percent) << " | "
                           << fmt("%.2f", r.error.max_abs_percent) << " |";
            md << '\n';
        }
        md << '\n';
    }

    // ---- plot: one point per (method, map): whole-set time against the worst map's error ----
    const fs::path dat = cfg.cache / "plot.dat";
    {
        std::ofstream d(dat);
        for (const Variant& v : variants) {
            d << "# " << v.name << v.param << '\n';
            for (const EnvMap& m : maps) {
                const Summary sm = summarise(v.name, v.param, m.name);
                d << sm.seconds << ' ' << std::max(sm.worst_rms, 1e-9) << ' ' << m.name << '\n';
            }
            d << "\n\n";
        }
        d << "# exact\n";
        for (const EnvMap& m : maps) {
            const Summary sm = summarise("exact", "", m.name);
            if (sm.have) d << sm.seconds << ' ' << 1e-9 << ' ' << m.name << '\n';
        }
    }
    const fs::path gp = cfg.cache / "plot.gp";
    {
        std::ofstream g(gp);
        g << "set terminal png size 1000,650 font ',11'\n"
          << "set output '" << (cfg.images / "convolution_speed_error.png").string() << "'\n"
          << "set logscale xy\nset format y '10^{%L}'\nset format x '10^{%L}'\n"
          << "set xlabel 'wall time, whole set (irradiance + " << ts.size() - 1
          << " reflection maps, reference sizes) [s], 2 threads'\n"
          << "set ylabel 'worst weighted relative RMS error vs exact'\n"
          << "set title 'Glint convolution, courtyard / studio / sunset / sun map (" << date << ")'\n"
          << "set key bottom left box opaque\nset grid\nset yrange [5e-10:100]\nset xrange [0.01:100]\n"
          << "set arrow from graph 0, first 0.01 to graph 1, first 0.01 nohead dt 2 lc rgb 'gray'\n"
          << "set label 'tolerance 1 %' at graph 0.02, first 0.013 tc rgb 'gray'\n"
          << "plot ";
        int idx = 0;
        for (const Variant& v : variants)
            g << "'" << dat.string() << "' index " << idx++ << " using 1:2 with points pt 7 ps 1.6 title '" << v.name
              << (v.param.empty() ? "" : " " + v.param) << "', ";
        g << "'" << dat.string() << "' index " << idx
          << " using 1:2 with points pt 4 ps 2 lw 2 title 'exact (error 0, drawn at 1e-9)'\n";
    }
    if (std::system(("gnuplot " + gp.string()).c_str()) != 0)
        std::fprintf(stderr, "bench: gnuplot failed; the plot was not written\n");
    std::fprintf(stderr, "bench: wrote %s, %s\n", (cfg.out / "convolution.md").c_str(),
                 (cfg.out / "convolution.csv").c_str());
    return 0;
}
