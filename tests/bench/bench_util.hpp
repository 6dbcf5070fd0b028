// Small helpers shared by the benchmarks' reports.
#pragma once

#include <unistd.h>

#include <cstdio>
#include <fstream>
#include <string>

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

// printf-style formatting of one number.
inline std::string fmt(const char* format, double value) {
    char buffer[64];
    std::snprintf(buffer, sizeof buffer, format, value);
    return buffer;
}

}  // namespace glint::bench
