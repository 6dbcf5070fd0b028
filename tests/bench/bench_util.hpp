// Small helpers shared by the benchmarks' reports.
#pragma once

#include <sys/resource.h>
#include <unistd.h>

#include <cstdio>
#include <fstream>
#include <string>
#include <vector>

#include "appliance/convolution/convolution.hpp"
#include "appliance/core/hdr_image.hpp"

namespace glint::bench {

// "CPU model, N cores" from /proc/cpuinfo, for the header of a results table.
inline std::string machine_description() {
    std::ifstream cpu("/proc/cpuinfo");
    std::string line, model = "unknown CPU";
    while (std::getline(cpu, line))
        if (line.rfind("model name", 0) == 0) {
            model = line.substr(line.find(':') + 2);
            break;
        }
    return model + ", " + std::to_string(sysconf(_SC_NPROCESSORS_ONLN)) + " cores";
}

// This process's peak resident memory so far, MiB (getrusage's ru_maxrss is in KiB on Linux).
inline double peak_rss_mib() {
    rusage usage{};
    getrusage(RUSAGE_SELF, &usage);
    return double(usage.ru_maxrss) / 1024.0;
}

// printf-style formatting of one number.
inline std::string fmt(const char* format, double value) {
    char buffer[64];
    std::snprintf(buffer, sizeof buffer, format, value);
    return buffer;
}

// The whole set: the irradiance map and these shininess values...
inline const std::vector<double>& whole_set_shininess() {
    static const std::vector<double> ns{1, 10, 20, 40, 80, 160, 320, 640, 1280, 5120, 20480};
    return ns;
}

// ...each at its reference output size: 128x64 for n <= 40, 256x128 for
// n <= 320, 512x256 above.
inline convolution::Size reference_size(double n) {
    if (n <= 40) return {128, 64};
    if (n <= 320) return {256, 128};
    return {512, 256};
}

// The capture benchmarks' downstream maps: irradiance (128x64) and n = 160 (256x128) of a map,
// by the auto engine on 2 threads.
inline std::vector<HdrImage> downstream_maps(const HdrImage& env) {
    std::vector<convolution::MapRequest> r{convolution::MapRequest::make_irradiance(),
                                           convolution::MapRequest::make_phong(160, "160")};
    r[0].size = convolution::Size{128, 64};
    r[1].size = convolution::Size{256, 128};
    convolution::Options o;
    o.threads = 2;
    std::vector<HdrImage> out;
    for (auto& m : convolution::convolve(env, r, o)) out.push_back(m.image);
    return out;
}

}  // namespace glint::bench
