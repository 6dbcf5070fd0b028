// The status page's system readings, against a temporary directory standing in for /sys and /proc.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "appliance/ui/system_status.hpp"

namespace fs = std::filesystem;
using namespace glint::ui;

namespace {

fs::path fresh_dir(const std::string& name) {
    const fs::path dir = fs::temp_directory_path() / ("glint_system_status_" + name);
    fs::remove_all(dir);
    fs::create_directories(dir);
    return dir;
}

void zone(const fs::path& root, const std::string& name, const std::string& temp) {
    fs::create_directories(root / name);
    if (!temp.empty()) std::ofstream(root / name / "temp") << temp;
}

}  // namespace

TEST(SystemStatus, TemperatureIsTheHottestReadableZone) {
    const fs::path root = fresh_dir("thermal");
    zone(root, "thermal_zone0", "48312\n");
    zone(root, "thermal_zone1", "61500\n");
    zone(root, "thermal_zone2", "");           // no temp file
    zone(root, "cooling_device0", "99000\n");  // not a thermal zone
    std::ofstream(root / "thermal_zone3") << "";  // a file, not a zone directory
    const auto t = cpu_temperature_c(root);
    ASSERT_TRUE(t.has_value());
    EXPECT_DOUBLE_EQ(*t, 61.5);
    EXPECT_EQ(temperature_text(t), "61.5 \xC2\xB0" "C");
}

TEST(SystemStatus, NoZonesReadsNotAvailable) {
    EXPECT_FALSE(cpu_temperature_c(fresh_dir("empty")).has_value());
    EXPECT_FALSE(cpu_temperature_c("/nonexistent/thermal").has_value());
    EXPECT_EQ(temperature_text(cpu_temperature_c("/nonexistent/thermal")), "n/a");
    const fs::path root = fresh_dir("garbage");
    zone(root, "thermal_zone0", "not a number");
    EXPECT_EQ(temperature_text(cpu_temperature_c(root)), "n/a");
}

TEST(SystemStatus, UptimeFromProcUptime) {
    const fs::path dir = fresh_dir("uptime");
    std::ofstream(dir / "uptime") << "273906.52 512345.10\n";
    const auto up = uptime_s(dir / "uptime");
    ASSERT_TRUE(up.has_value());
    EXPECT_DOUBLE_EQ(*up, 273906.52);
    EXPECT_EQ(duration_text(up), "3 d 04:05:06");
    EXPECT_EQ(duration_text(59.9), "00:00:59");
    EXPECT_EQ(duration_text(uptime_s(dir / "missing")), "n/a");
}

TEST(SystemStatus, FreeDiskOfATemporaryDirectory) {
    const auto free = free_disk_bytes(fs::temp_directory_path());
    ASSERT_TRUE(free.has_value());
    EXPECT_GT(*free, 0u);
    EXPECT_FALSE(free_disk_bytes("/nonexistent/disk").has_value());
    EXPECT_EQ(bytes_text(std::uint64_t(12'400'000'000)), "12.4 GB");
    EXPECT_EQ(bytes_text(std::uint64_t(999)), "999 B");
    EXPECT_EQ(bytes_text(std::nullopt), "n/a");
    // This machine's real readings run too (whatever they are).
    EXPECT_FALSE(duration_text(uptime_s()).empty());
    EXPECT_FALSE(temperature_text(cpu_temperature_c()).empty());
}
