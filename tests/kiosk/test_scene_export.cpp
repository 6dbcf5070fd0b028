// The maintenance menu's export (appliance/app/scene_export.hpp): the asked-for files copied
// whole into a dated directory, a cut-short export's leftovers removed, errors naming the place.
#include <gtest/gtest.h>

#include <unistd.h>

#include <filesystem>
#include <fstream>

#include <nlohmann/json.hpp>

#include "appliance/app/scene_export.hpp"
#include "appliance/core/errors.hpp"
#include "appliance/core/exr_io.hpp"
#include "appliance/render/maps.hpp"
#include "appliance/render/material.hpp"

namespace glint::app {
namespace {

namespace fs = std::filesystem;

class SceneExport : public ::testing::Test {
protected:
    void SetUp() override {
        root_ = fs::temp_directory_path() / ("glint-export-" + std::to_string(::getpid()));
        fs::remove_all(root_);
        for (const char* d : {"maps", "frames", "sessions/visit-1/frames", "stick"}) fs::create_directories(root_ / d);
        write(root_ / "maps/env.exr", 1000);
        write(root_ / "maps/env.coverage.exr", 300);
        write(root_ / "maps/unrelated.txt", 5);
        write(root_ / "frames/00001_AR.png", 200);
        write(root_ / "frames/notes.txt", 5);
        write(root_ / "sessions/visit-1/frames.csv", 50);
        write(root_ / "sessions/visit-1/frames/000000.jpg", 400);
    }
    void TearDown() override { fs::remove_all(root_); }
    static void write(const fs::path& p, std::size_t bytes) { std::ofstream(p) << std::string(bytes, 'x'); }
    ExportSources sources() const { return {root_ / "maps", root_ / "frames", root_ / "sessions"}; }

    fs::path root_;
};

TEST_F(SceneExport, CopiesWhatWasAskedForIntoADatedDirectory) {
    const ExportResult r = export_scene(1 | 4, sources(), root_ / "stick", "20261203-061500");
    EXPECT_EQ(r.dir, root_ / "stick/glint-20261203-061500");
    EXPECT_EQ(r.files, 3);
    EXPECT_EQ(r.bytes, 1500u);
    EXPECT_EQ(fs::file_size(r.dir / "env.exr"), 1000u);
    EXPECT_EQ(fs::file_size(r.dir / "env.coverage.exr"), 300u);
    EXPECT_EQ(fs::file_size(r.dir / "frames/00001_AR.png"), 200u);
    EXPECT_FALSE(fs::exists(r.dir / "unrelated.txt"));
    EXPECT_FALSE(fs::exists(r.dir / "sessions"));
    EXPECT_FALSE(fs::exists(root_ / "stick/glint-20261203-061500.partial"));
    EXPECT_NE(r.summary().find("wrote 3 files"), std::string::npos);

    const ExportResult s = export_scene(8, sources(), root_ / "stick", "20261203-061600");
    EXPECT_EQ(s.files, 2);
    EXPECT_EQ(fs::file_size(s.dir / "sessions/visit-1/frames/000000.jpg"), 400u);
}

TEST_F(SceneExport, ACutShortExportIsRemovedAndNothingIsWrittenOver) {
    fs::create_directories(root_ / "stick/glint-20261203-050000.partial/frames");
    write(root_ / "stick/glint-20261203-050000.partial/env.exr", 10);
    fs::create_directories(root_ / "stick/photos.partial");  // not ours: left alone
    export_scene(1, sources(), root_ / "stick", "20261203-061500");
    EXPECT_FALSE(fs::exists(root_ / "stick/glint-20261203-050000.partial"));
    EXPECT_TRUE(fs::exists(root_ / "stick/photos.partial"));
    EXPECT_THROW(export_scene(1, sources(), root_ / "stick", "20261203-061500"), InputError);  // exists already
}

TEST_F(SceneExport, ErrorsNameThePlaceAtFault) {
    try {
        export_scene(1, sources(), root_ / "no-stick", "20261203-061500");
        FAIL() << "no error";
    } catch (const InputError& e) {
        EXPECT_NE(std::string(e.what()).find("no-stick"), std::string::npos) << e.what();
    }
    EXPECT_THROW(export_scene(1, {"", "", ""}, root_ / "stick", "20261203-061500"), InputError);  // nothing to export
    EXPECT_THROW(export_scene(2, sources(), root_ / "stick", "20261203-061500"), InputError);      // no maps lit anything yet
    EXPECT_TRUE(fs::is_empty(root_ / "stick"));
}

// The shading maps are written from memory: each map whole (read back equal), and maps.json
// saying each one's size and where it came from.
TEST_F(SceneExport, WritesTheShadingMapsFromMemory) {
    render::ShadingMaps maps;
    HdrImage irradiance(8, 4);
    for (std::size_t k = 0; k < irradiance.data().size(); ++k) irradiance.data()[k] = float(k) * 0.25f;
    maps.irradiance = irradiance;
    maps.irradiance_from = "live (GPU): sh";
    HdrImage mirror(16, 8);
    for (std::size_t k = 0; k < mirror.data().size(); ++k) mirror.data()[k] = 100.0f + 0.5f * float(k);  // positive: the loader sets negatives to 0
    maps.set_reflection(render::parse_material("mirror"), mirror, "coarse: cone");
    ExportSources from = sources();
    from.shading_maps = &maps;
    const ExportResult r = export_scene(2, from, root_ / "stick", "20261203-070000");
    EXPECT_EQ(r.files, 3);  // irradiance.exr, mirror.exr, maps.json
    const fs::path dir = root_ / "stick/glint-20261203-070000/maps";
    EXPECT_EQ(load_exr(dir / "irradiance.exr").image.data(), irradiance.data());
    const std::string lobe = maps.reflections.front().request.label;
    EXPECT_EQ(load_exr(dir / (lobe + ".exr")).image.data(), mirror.data());
    const nlohmann::json index = nlohmann::json::parse(std::ifstream(dir / "maps.json"));
    EXPECT_EQ(index["irradiance.exr"]["width"], 8);
    EXPECT_EQ(index["irradiance.exr"]["from"], "live (GPU): sh");
    EXPECT_EQ(index[lobe + ".exr"]["from"], "coarse: cone");
    EXPECT_EQ(index[lobe + ".exr"]["lookup"], "bilinear");  // a lobe map's would say "lobe"
    EXPECT_FALSE(fs::exists(root_ / "stick/glint-20261203-070000/env.exr"));  // only what was asked for
}

TEST(UtcStamp, HasTheDatedNamesShape) {
    const std::string s = utc_stamp();
    ASSERT_EQ(s.size(), 15u);
    EXPECT_EQ(s[8], '-');
    EXPECT_EQ(s.substr(0, 2), "20");
}

}  // namespace
}  // namespace glint::app
