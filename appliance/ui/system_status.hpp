// What the maintenance menu's status page reads from the system: the CPU's temperature (the
// thermal zones of /sys/class/thermal), the free space of a file system (statvfs) and the
// system's uptime (/proc/uptime). Each takes its root so tests point it at a temporary directory;
// what is absent reads as "n/a", never as an error: a board without thermal zones is not broken.
#pragma once

#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>

namespace glint::ui {

// The hottest of root/thermal_zone*/temp (millidegrees Celsius, as the kernel writes them), in
// degrees; nullopt when there is no readable zone. The hottest: a technician wants the worst.
std::optional<double> cpu_temperature_c(const std::filesystem::path& thermal_root = "/sys/class/thermal");
// Space an unprivileged process may still write on the file system holding `path`, in bytes.
std::optional<std::uint64_t> free_disk_bytes(const std::filesystem::path& path);
// Seconds since boot: the first number of /proc/uptime.
std::optional<double> uptime_s(const std::filesystem::path& proc_uptime = "/proc/uptime");

// As the status page shows them: "52.3 °C", "12.4 GB", "3 d 04:05:06"; "n/a" for nullopt.
std::string temperature_text(std::optional<double> celsius);
std::string bytes_text(std::optional<std::uint64_t> bytes);
std::string duration_text(std::optional<double> seconds);

}  // namespace glint::ui
