// The maintenance menu's export (docs/kiosk.md, "Maintenance menu"): the visitor's environment map
// and coverage, the shading maps the object is lit with (written from memory: the kiosk keeps
// them nowhere else), the PNG frames and the recorded sessions, to a mounted USB stick, all or
// nothing: into EXPORT_DIR/glint-YYYYMMDD-HHMMSS.partial, every file synced, then renamed to
// EXPORT_DIR/glint-YYYYMMDD-HHMMSS and the directory synced. A stick pulled or full half-way
// leaves only the .partial directory, which the next export removes.
#pragma once

#include <cstdint>
#include <filesystem>
#include <string>

namespace glint::render {
struct ShadingMaps;
}

namespace glint::app {

struct ExportSources {
    std::filesystem::path maps_dir;      // env.exr and env.coverage.exr ("" = none)
    std::filesystem::path frames_dir;    // *.png ("" = none)
    std::filesystem::path sessions_dir;  // recorded sessions, one directory each ("" = none)
    // The maps the object is lit with now (null = none): written as maps/irradiance.exr,
    // maps/<lobe>.exr (phong_160, mirror, ...) and maps/maps.json (each map's size and where it
    // came from: coarse ones say so).
    const render::ShadingMaps* shading_maps = nullptr;
};

struct ExportResult {
    std::filesystem::path dir;  // where it went
    int files = 0;
    std::uintmax_t bytes = 0;
    std::string summary() const;  // "wrote 3 files (5.2 MB) to /media/usb/glint-20261203-061500"
};

// `items`: bits of ui::ExportItem (env map 1, shading maps 2, screenshots 4, sessions 8). `stamp`: the name's time, UTC
// "YYYYMMDD-HHMMSS". Throws InputError naming the place at fault (no such export directory,
// nothing to export) and RuntimeError for a failed copy (the partial directory is removed).
ExportResult export_scene(std::uint8_t items, const ExportSources& from, const std::filesystem::path& export_dir,
                          const std::string& stamp);

// The current UTC time as "YYYYMMDD-HHMMSS".
std::string utc_stamp();

}  // namespace glint::app
