#include "appliance/ui/system_status.hpp"

#include <sys/statvfs.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <system_error>

namespace glint::ui {

std::optional<double> cpu_temperature_c(const std::filesystem::path& thermal_root) {
    std::optional<double> hottest;
    std::error_code error;
    for (std::filesystem::directory_iterator it(thermal_root, error), end; !error && it != end; it.increment(error)) {
        if (it->path().filename().string().rfind("thermal_zone", 0) != 0) continue;
        // A zone whose sensor is asleep or gone fails to read (EAGAIN, ENODEV): skip it.
        std::ifstream file(it->path() / "temp");
        long long milli = 0;
        if (!(file >> milli)) continue;
        const double celsius = double(milli) / 1000.0;
        if (!hottest || celsius > *hottest) hottest = celsius;
    }
    return hottest;
}

std::optional<std::uint64_t> free_disk_bytes(const std::filesystem::path& path) {
    struct statvfs s {};
    if (statvfs(path.c_str(), &s) != 0) return std::nullopt;
    return std::uint64_t(s.f_bavail) * std::uint64_t(s.f_frsize);
}

std::optional<double> uptime_s(const std::filesystem::path& proc_uptime) {
    std::ifstream file(proc_uptime);
    double seconds = 0;
    if (!(file >> seconds) || seconds < 0) return std::nullopt;
    return seconds;
}

std::string temperature_text(std::optional<double> celsius) {
    if (!celsius) return "n/a";
    char text[32];
    std::snprintf(text, sizeof text, "%.1f \xC2\xB0" "C", *celsius);  // U+00B0, in the fonts' Latin-1
    return text;
}

std::string bytes_text(std::optional<std::uint64_t> bytes) {
    if (!bytes) return "n/a";
    const char* units[] = {"B", "kB", "MB", "GB", "TB"};
    double value = double(*bytes);
    int unit = 0;
    while (value >= 1000 && unit < 4) {
        value /= 1000;
        ++unit;
    }
    char text[32];
    std::snprintf(text, sizeof text, unit == 0 ? "%.0f %s" : "%.1f %s", value, units[unit]);
    return text;
}

std::string duration_text(std::optional<double> seconds) {
    if (!seconds) return "n/a";
    const auto total = static_cast<long long>(std::floor(*seconds));
    const long long days = total / 86400, h = total / 3600 % 24, m = total / 60 % 60, s = total % 60;
    char text[48];
    if (days > 0)
        std::snprintf(text, sizeof text, "%lld d %02lld:%02lld:%02lld", days, h, m, s);
    else
        std::snprintf(text, sizeof text, "%02lld:%02lld:%02lld", h, m, s);
    return text;
}

}  // namespace glint::ui
