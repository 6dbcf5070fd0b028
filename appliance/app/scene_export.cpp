#include "appliance/app/scene_export.hpp"

#include <fcntl.h>
#include <unistd.h>

#include <cerrno>
#include <cmath>
#include <cstring>
#include <ctime>
#include <list>
#include <vector>

#include <nlohmann/json.hpp>

#include "appliance/core/atomic_file.hpp"
#include "appliance/core/errors.hpp"
#include "appliance/core/exr_io.hpp"
#include "appliance/render/maps.hpp"

namespace glint::app {
namespace fs = std::filesystem;

namespace {

// Copies and fsyncs one file; throws RuntimeError naming it.
std::uintmax_t copy_synced(const fs::path& from, const fs::path& to) {
    std::error_code ec;
    fs::create_directories(to.parent_path(), ec);
    if (ec) throw RuntimeError("export: cannot create " + to.parent_path().string() + ": " + ec.message());
    if (!fs::copy_file(from, to, fs::copy_options::overwrite_existing, ec))
        throw RuntimeError("export: cannot copy " + from.string() + " to " + to.string() + ": " + ec.message());
    const int fd = ::open(to.c_str(), O_RDONLY);
    if (fd < 0 || ::fsync(fd) != 0) {
        const std::string why = std::strerror(errno);
        if (fd >= 0) ::close(fd);
        throw RuntimeError("export: cannot sync " + to.string() + ": " + why);
    }
    ::close(fd);
    return fs::file_size(to);
}

}  // namespace

std::string ExportResult::summary() const {
    char text[64];
    std::snprintf(text, sizeof text, "wrote %d files (%.1f MB) to ", files, double(bytes) / 1e6);
    return text + dir.string();
}

std::string utc_stamp() {
    const std::time_t now = std::time(nullptr);
    std::tm utc{};
    gmtime_r(&now, &utc);
    char text[32];
    std::strftime(text, sizeof text, "%Y%m%d-%H%M%S", &utc);
    return text;
}

ExportResult export_scene(std::uint8_t items, const ExportSources& from, const fs::path& export_dir, const std::string& stamp) {
    std::error_code ec;
    if (!fs::is_directory(export_dir, ec)) throw InputError("export: " + export_dir.string() + " is not there (no stick mounted?)");
    // What to copy: (source, name under the export).
    std::vector<std::pair<fs::path, fs::path>> files;
    if ((items & 1) && !from.maps_dir.empty())
        for (const char* name : {"env.exr", "env.coverage.exr"})
            if (fs::is_regular_file(from.maps_dir / name, ec)) files.emplace_back(from.maps_dir / name, name);
    if ((items & 4) && fs::is_directory(from.frames_dir, ec))
        for (const fs::directory_entry& e : fs::directory_iterator(from.frames_dir))
            if (e.is_regular_file() && e.path().extension() == ".png") files.emplace_back(e.path(), fs::path("frames") / e.path().filename());
    if ((items & 8) && fs::is_directory(from.sessions_dir, ec))
        for (const fs::directory_entry& e : fs::recursive_directory_iterator(from.sessions_dir))
            if (e.is_regular_file()) files.emplace_back(e.path(), fs::path("sessions") / fs::relative(e.path(), from.sessions_dir));
    // The shading maps, from memory: (image, name under the export, where it came from).
    struct MapToWrite {
        const HdrImage* image;
        fs::path name;
        std::string from;
        MapLookup lookup = MapLookup::Bilinear;  // how a reader reads it between texels (maps.json)
        double shininess = 0;                    // a reflection map's Phong exponent (maps.json); 0: none
    };
    std::vector<MapToWrite> maps;
    std::list<HdrImage> whole_grids;  // maps with fine tiles are exported as their whole finer grid
    if ((items & 2) && from.shading_maps) {
        const render::ShadingMaps& m = *from.shading_maps;
        if (m.irradiance) maps.push_back({&*m.irradiance, "maps/irradiance.exr", m.irradiance_from});
        for (const render::ReflectionMap& r : m.reflections) {
            const HdrImage* image = &r.image;
            if (!r.fine.empty()) image = &whole_grids.emplace_back(r.whole_grid());
            maps.push_back({image, fs::path("maps") / (r.request.label + ".exr"), r.from, r.lookup,
                            r.request.mirror ? 0.0 : r.request.shininess});
        }
    }
    if (files.empty() && maps.empty())
        throw InputError("export: nothing to export (no map, frames or sessions of the kinds asked for)");

    // Leftovers of an export cut short are removed first.
    for (const fs::directory_entry& e : fs::directory_iterator(export_dir, ec))
        if (e.path().extension() == ".partial" && e.path().filename().string().rfind("glint-", 0) == 0) fs::remove_all(e.path(), ec);
    ExportResult r;
    r.dir = export_dir / ("glint-" + stamp);
    if (fs::exists(r.dir, ec)) throw InputError("export: " + r.dir.string() + " exists already");
    const fs::path partial = export_dir / ("glint-" + stamp + ".partial");
    try {
        for (const auto& [source, name] : files) {
            r.bytes += copy_synced(source, partial / name);
            ++r.files;
        }
        if (!maps.empty()) {
            nlohmann::json index = nlohmann::json::object();
            for (const MapToWrite& m : maps) {
                fs::create_directories((partial / m.name).parent_path());
                save_exr(partial / m.name, *m.image, ExrCompression::None);  // synced by save_exr
                r.bytes += fs::file_size(partial / m.name);
                ++r.files;
                index[m.name.filename().string()] = {{"width", m.image->width()}, {"height", m.image->height()}, {"from", m.from},
                                                    {"lookup", to_string(m.lookup)}};
                // The lobe a lobe-lookup map is read through (glint compare reads it from here).
                if (m.shininess > 0 && std::isfinite(m.shininess))
                    index[m.name.filename().string()]["shininess"] = m.shininess;
            }
            write_text_atomically(partial / "maps" / "maps.json", index.dump(2) + "\n");
            r.bytes += fs::file_size(partial / "maps" / "maps.json");
            ++r.files;
        }
        sync_directory(partial);
        fs::rename(partial, r.dir);
        sync_directory(export_dir);
    } catch (const std::filesystem::filesystem_error& e) {
        fs::remove_all(partial, ec);
        throw RuntimeError(std::string("export: ") + e.what());
    } catch (...) {
        fs::remove_all(partial, ec);
        throw;
    }
    return r;
}

}  // namespace glint::app
