// Tests of core/exr_io: formats and channel layouts the loader accepts, sanitising, errors, atomic saves.
#include <gtest/gtest.h>

#include "tests/unit/test_support.hpp"
#include <sys/resource.h>
#include <unistd.h>

#include <ImfChannelList.h>
#include <ImfFrameBuffer.h>
#include <ImfHeader.h>
#include <ImfInputFile.h>
#include <ImfOutputFile.h>
#include <ImfTileDescription.h>
#include <ImfTiledOutputFile.h>
#include <half.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <functional>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include "appliance/core/errors.hpp"
#include "appliance/core/exr_io.hpp"

namespace glint {
namespace {

namespace fs = std::filesystem;

class ExrIo : public glint::testing::TempDirTest {};

struct ChannelSpec {
    std::string name;
    Imf::PixelType type;
};

// Writes a file with Imf directly, so the loader is tested against layouts that
// save_exr never produces. value(channel, x, y) gives each sample.
void write_exr(const fs::path& path, int w, int h, const std::vector<ChannelSpec>& channels,
               const std::function<float(const std::string&, int, int)>& value,
               Imath::V2i origin = {0, 0}) {
    Imath::Box2i dw(origin, origin + Imath::V2i(w - 1, h - 1));
    Imf::Header header(dw, dw);
    for (const auto& c : channels) header.channels().insert(c.name, Imf::Channel(c.type));
    const std::size_t n = std::size_t(w) * std::size_t(h);
    std::vector<std::vector<half>> halves(channels.size(), std::vector<half>(n));
    std::vector<std::vector<float>> floats(channels.size(), std::vector<float>(n));
    std::vector<std::vector<std::uint32_t>> uints(channels.size(), std::vector<std::uint32_t>(n));
    Imf::FrameBuffer fb;
    for (std::size_t c = 0; c < channels.size(); ++c) {
        for (int y = 0; y < h; ++y)
            for (int x = 0; x < w; ++x) {
                const float v = value(channels[c].name, x, y);
                const std::size_t k = std::size_t(y) * std::size_t(w) + std::size_t(x);
                halves[c][k] = half(v);
                floats[c][k] = v;
                uints[c][k] = std::uint32_t(v);
            }
        char* base = nullptr;
        std::size_t size = 0;
        switch (channels[c].type) {
            case Imf::HALF:
                base = reinterpret_cast<char*>(halves[c].data());
                size = sizeof(half);
                break;
            case Imf::FLOAT:
                base = reinterpret_cast<char*>(floats[c].data());
                size = sizeof(float);
                break;
            default:
                base = reinterpret_cast<char*>(uints[c].data());
                size = sizeof(std::uint32_t);
                break;
        }
        const std::ptrdiff_t shift =
            (std::ptrdiff_t(origin.x) + std::ptrdiff_t(origin.y) * w) * std::ptrdiff_t(size);
        fb.insert(channels[c].name,
                  Imf::Slice(channels[c].type, base - shift, size, size * std::size_t(w)));
    }
    Imf::OutputFile file(path.c_str(), header);
    file.setFrameBuffer(fb);
    file.writePixels(h);
}

HdrImage pattern(int w, int h) {
    HdrImage img(w, h);
    std::mt19937 rng(42);
    std::uniform_real_distribution<float> dist(0.0f, 100.0f);
    for (float& v : img.data()) v = dist(rng);
    return img;
}

void write_bytes(const fs::path& path, const std::string& bytes) {
    std::ofstream out(path, std::ios::binary);
    out.write(bytes.data(), std::streamsize(bytes.size()));
}

// Expects load_exr(path) to throw InputError whose message names the file.
void expect_input_error_naming(const fs::path& path) {
    try {
        load_exr(path);
        ADD_FAILURE() << "load_exr(" << path << ") did not throw";
    } catch (const InputError& e) {
        EXPECT_NE(std::string(e.what()).find(path.string()), std::string::npos)
            << "message does not name the file: " << e.what();
    } catch (const std::exception& e) {
        ADD_FAILURE() << "load_exr(" << path << ") threw something other than InputError: "
                      << e.what();
    }
}

TEST_F(ExrIo, SaveThenLoadRoundTripsFloatExactly) {
    const HdrImage img = pattern(37, 19);
    const fs::path path = dir_ / "map.exr";
    save_exr(path, img);
    const LoadedExr loaded = load_exr(path);
    EXPECT_EQ(loaded.image.width(), 37);
    EXPECT_EQ(loaded.image.height(), 19);
    EXPECT_EQ(loaded.image.data(), img.data());
    EXPECT_EQ(loaded.sanitised.total(), 0u);
    EXPECT_FALSE(loaded.luminance_only);

    // The file holds FLOAT R, G, B (the conventions' format), nothing else.
    Imf::InputFile file(path.c_str());
    const Imf::ChannelList& ch = file.header().channels();
    int count = 0;
    for (auto it = ch.begin(); it != ch.end(); ++it, ++count)
        EXPECT_EQ(it.channel().type, Imf::FLOAT) << it.name();
    EXPECT_EQ(count, 3);
    EXPECT_NE(ch.findChannel("R"), nullptr);
    EXPECT_NE(ch.findChannel("G"), nullptr);
    EXPECT_NE(ch.findChannel("B"), nullptr);
}

TEST_F(ExrIo, SaveOverwritesAnExistingFile) {
    const fs::path path = dir_ / "map.exr";
    save_exr(path, pattern(8, 4));
    HdrImage second(16, 8);
    for (float& v : second.data()) v = 3.0f;
    save_exr(path, second);
    const LoadedExr loaded = load_exr(path);
    EXPECT_EQ(loaded.image.width(), 16);
    EXPECT_EQ(loaded.image.data(), second.data());
}

TEST_F(ExrIo, LoadsHalfChannels) {
    const fs::path path = dir_ / "half.exr";
    // Values exactly representable in half.
    write_exr(path, 6, 3, {{"R", Imf::HALF}, {"G", Imf::HALF}, {"B", Imf::HALF}},
              [](const std::string& c, int x, int y) {
                  return c == "R" ? 0.25f * float(x) : c == "G" ? 1000.0f + float(y) : 1.5f;
              });
    const LoadedExr loaded = load_exr(path);
    ASSERT_EQ(loaded.image.width(), 6);
    ASSERT_EQ(loaded.image.height(), 3);
    for (int y = 0; y < 3; ++y)
        for (int x = 0; x < 6; ++x) {
            const Rgb c = loaded.image.at(x, y);
            EXPECT_EQ(c.r, 0.25f * float(x));
            EXPECT_EQ(c.g, 1000.0f + float(y));
            EXPECT_EQ(c.b, 1.5f);
        }
    EXPECT_FALSE(loaded.luminance_only);
    EXPECT_EQ(loaded.sanitised.total(), 0u);
}

TEST_F(ExrIo, LoadsChannelsInAnyOrderAndIgnoresExtraOnes) {
    const fs::path path = dir_ / "bgra.exr";
    // B, G, R declared in that order, mixed types, plus alpha and depth that must be
    // ignored (their negative values must not count as sanitised texels either).
    write_exr(path, 5, 4,
              {{"B", Imf::FLOAT}, {"A", Imf::HALF}, {"G", Imf::HALF}, {"R", Imf::FLOAT},
               {"Z", Imf::FLOAT}},
              [](const std::string& c, int x, int y) {
                  if (c == "R") return float(x + 1);
                  if (c == "G") return float(10 * (y + 1));
                  if (c == "B") return float(100 + x + 5 * y);
                  return -7.0f;
              });
    const LoadedExr loaded = load_exr(path);
    for (int y = 0; y < 4; ++y)
        for (int x = 0; x < 5; ++x) {
            const Rgb c = loaded.image.at(x, y);
            EXPECT_EQ(c.r, float(x + 1));
            EXPECT_EQ(c.g, float(10 * (y + 1)));
            EXPECT_EQ(c.b, float(100 + x + 5 * y));
        }
    EXPECT_EQ(loaded.sanitised.total(), 0u);
    EXPECT_FALSE(loaded.luminance_only);
}

TEST_F(ExrIo, LoadsUintChannels) {
    const fs::path path = dir_ / "uint.exr";
    write_exr(path, 4, 2, {{"R", Imf::UINT}, {"G", Imf::UINT}, {"B", Imf::UINT}},
              [](const std::string& c, int x, int y) {
                  return float(x + 4 * y + (c == "R" ? 0 : c == "G" ? 100 : 200));
              });
    const LoadedExr loaded = load_exr(path);
    for (int y = 0; y < 2; ++y)
        for (int x = 0; x < 4; ++x) {
            EXPECT_EQ(loaded.image.at(x, y).r, float(x + 4 * y));
            EXPECT_EQ(loaded.image.at(x, y).g, float(x + 4 * y + 100));
            EXPECT_EQ(loaded.image.at(x, y).b, float(x + 4 * y + 200));
        }
}

TEST_F(ExrIo, LuminanceOnlyIsCopiedToRgb) {
    const fs::path path = dir_ / "y.exr";
    write_exr(path, 7, 3, {{"Y", Imf::HALF}},
              [](const std::string&, int x, int y) { return float(x + 10 * y) + 0.5f; });
    const LoadedExr loaded = load_exr(path);
    EXPECT_TRUE(loaded.luminance_only);
    for (int y = 0; y < 3; ++y)
        for (int x = 0; x < 7; ++x) {
            const float v = float(x + 10 * y) + 0.5f;
            const Rgb c = loaded.image.at(x, y);
            EXPECT_EQ(c.r, v) << x << "," << y;
            EXPECT_EQ(c.g, v) << x << "," << y;
            EXPECT_EQ(c.b, v) << x << "," << y;
        }
}

TEST_F(ExrIo, RgbWinsOverY) {
    const fs::path path = dir_ / "rgby.exr";
    write_exr(path, 2, 2, {{"R", Imf::FLOAT}, {"G", Imf::FLOAT}, {"B", Imf::FLOAT}, {"Y", Imf::FLOAT}},
              [](const std::string& c, int, int) { return c == "Y" ? 9.0f : 1.0f; });
    const LoadedExr loaded = load_exr(path);
    EXPECT_FALSE(loaded.luminance_only);
    EXPECT_EQ(loaded.image.at(1, 1).r, 1.0f);
}

TEST_F(ExrIo, DataWindowWithAnOffsetOriginIsTheImage) {
    const fs::path path = dir_ / "offset.exr";
    write_exr(path, 4, 3, {{"R", Imf::FLOAT}, {"G", Imf::FLOAT}, {"B", Imf::FLOAT}},
              [](const std::string& c, int x, int y) {
                  return float(x + 10 * y) + (c == "R" ? 0.0f : c == "G" ? 0.25f : 0.5f);
              },
              {-3, 17});
    const LoadedExr loaded = load_exr(path);
    ASSERT_EQ(loaded.image.width(), 4);
    ASSERT_EQ(loaded.image.height(), 3);
    for (int y = 0; y < 3; ++y)
        for (int x = 0; x < 4; ++x) {
            EXPECT_EQ(loaded.image.at(x, y).r, float(x + 10 * y));
            EXPECT_EQ(loaded.image.at(x, y).b, float(x + 10 * y) + 0.5f);
        }
}

TEST_F(ExrIo, LoadsTiledFiles) {
    const fs::path path = dir_ / "tiled.exr";
    const int w = 13, h = 9;
    {
        Imf::Header header(w, h);
        for (const char* n : {"R", "G", "B"}) header.channels().insert(n, Imf::Channel(Imf::FLOAT));
        header.setTileDescription(Imf::TileDescription(4, 4, Imf::ONE_LEVEL));
        std::vector<float> px(std::size_t(w * h) * 3);
        for (std::size_t k = 0; k < px.size(); ++k) px[k] = float(k);
        Imf::TiledOutputFile file(path.c_str(), header);
        Imf::FrameBuffer fb;
        char* base = reinterpret_cast<char*>(px.data());
        for (int c = 0; c < 3; ++c)
            fb.insert(c == 0 ? "R" : c == 1 ? "G" : "B",
                      Imf::Slice(Imf::FLOAT, base + c * sizeof(float), 3 * sizeof(float),
                                 3 * sizeof(float) * std::size_t(w)));
        file.setFrameBuffer(fb);
        file.writeTiles(0, file.numXTiles() - 1, 0, file.numYTiles() - 1);
    }
    const LoadedExr loaded = load_exr(path);
    ASSERT_EQ(loaded.image.width(), w);
    ASSERT_EQ(loaded.image.height(), h);
    for (std::size_t k = 0; k < loaded.image.data().size(); ++k)
        ASSERT_EQ(loaded.image.data()[k], float(k));
}

TEST_F(ExrIo, NonFiniteAndNegativeValuesAreSanitisedAndCounted) {
    const fs::path path = dir_ / "bad.exr";
    const float nan = std::numeric_limits<float>::quiet_NaN();
    const float inf = std::numeric_limits<float>::infinity();
    // Row 0: R holds NaN, +Inf, -Inf, -2, -0.001, 3.
    // G holds one more NaN at x = 5; B is clean.
    const std::vector<float> r_row = {nan, inf, -inf, -2.0f, -1e-3f, 3.0f};
    write_exr(path, 6, 2, {{"R", Imf::FLOAT}, {"G", Imf::FLOAT}, {"B", Imf::FLOAT}},
              [&](const std::string& c, int x, int y) {
                  if (y != 0) return 1.0f;
                  if (c == "R") return r_row[std::size_t(x)];
                  if (c == "G") return x == 5 ? nan : 2.0f;
                  return 4.0f;
              });
    const LoadedExr loaded = load_exr(path);
    EXPECT_EQ(loaded.sanitised.nan, 2u);
    EXPECT_EQ(loaded.sanitised.pos_inf, 1u);
    EXPECT_EQ(loaded.sanitised.neg_inf, 1u);
    EXPECT_EQ(loaded.sanitised.negative, 2u);
    EXPECT_EQ(loaded.sanitised.total(), 6u);
    const std::vector<float> expected_r = {0.0f, 65504.0f, 0.0f, 0.0f, 0.0f, 3.0f};
    for (int x = 0; x < 6; ++x) {
        EXPECT_EQ(loaded.image.at(x, 0).r, expected_r[std::size_t(x)]) << x;
        EXPECT_EQ(loaded.image.at(x, 0).g, x == 5 ? 0.0f : 2.0f) << x;
        EXPECT_EQ(loaded.image.at(x, 0).b, 4.0f) << x;
        EXPECT_EQ(loaded.image.at(x, 1).r, 1.0f) << x;
    }
    for (float v : loaded.image.data()) {
        EXPECT_TRUE(std::isfinite(v));
        EXPECT_GE(v, 0.0f);
    }
}

TEST_F(ExrIo, HalfInfinityIsSanitisedToTheLargestHalf) {
    const fs::path path = dir_ / "halfinf.exr";
    const float inf = std::numeric_limits<float>::infinity();
    write_exr(path, 2, 1, {{"R", Imf::HALF}, {"G", Imf::HALF}, {"B", Imf::HALF}},
              [&](const std::string& c, int x, int) {
                  return c == "R" ? (x == 0 ? inf : -inf) : 1.0f;
              });
    const LoadedExr loaded = load_exr(path);
    EXPECT_EQ(loaded.image.at(0, 0).r, kMaxFiniteHalf);
    EXPECT_EQ(loaded.image.at(1, 0).r, 0.0f);
    EXPECT_EQ(loaded.sanitised.pos_inf, 1u);
    EXPECT_EQ(loaded.sanitised.neg_inf, 1u);
    EXPECT_EQ(loaded.sanitised.total(), 2u);
}

TEST_F(ExrIo, TruncatedFileIsAnInputErrorNamingIt) {
    const fs::path path = dir_ / "truncated.exr";
    save_exr(path, pattern(64, 32));  // random texels: ZIP cannot shrink them much
    const auto size = fs::file_size(path);
    ASSERT_GT(size, 4096u);
    fs::resize_file(path, size / 2);
    expect_input_error_naming(path);
}

// load_exr(path)'s InputError message (a failure when it loads), checking that the peak resident
// size did not grow by a refused image's size (each CTest test runs in its own process, so the
// peak is the test's).
std::string load_error_without_allocating(const fs::path& path) {
    rusage before{};
    getrusage(RUSAGE_SELF, &before);
    std::string error;
    try {
        load_exr(path);
        ADD_FAILURE() << "accepted " << path;
    } catch (const InputError& e) {
        error = e.what();
    }
    rusage after{};
    getrusage(RUSAGE_SELF, &after);
    EXPECT_LT(after.ru_maxrss - before.ru_maxrss, 256 * 1024) << "KiB of peak resident size added";
    return error;
}

// A header naming a large data window over a file without its scanlines is refused before the
// image is allocated: 16384x8192 asked for 1.5 GiB (and 32768x32768 for 12 GiB) before the
// truncation was noticed (found with tests/fuzz's exr target). The peak resident size must not
// grow by the image's size (each CTest test runs in its own process, so the peak is this test's).
TEST_F(ExrIo, TruncatedHugeImageIsRefusedBeforeItIsAllocated) {
    const fs::path path = dir_ / "huge_truncated.exr";
    {
        Imf::Header header(16384, 8192);
        header.compression() = Imf::ZIP_COMPRESSION;
        for (const char* c : {"R", "G", "B"}) header.channels().insert(c, Imf::Channel(Imf::HALF));
        Imf::OutputFile out(path.c_str(), header);  // no scanlines: the header and an empty offset table
    }
    ASSERT_LT(fs::file_size(path), 8192u);
    const std::string error = load_error_without_allocating(path);
    EXPECT_NE(error.find("truncated"), std::string::npos) << error;
}

// A complete file whose header claims far more texels than its bytes could hold under any EXR
// compression (found with tests/fuzz's exr target: 469 bytes of RLE claiming 67108872x4 texels,
// a 3 GiB allocation) is refused as damaged before the image is allocated.
TEST_F(ExrIo, AHeaderClaimingMoreThanTheFileCanHoldIsRefusedBeforeItIsAllocated) {
    const fs::path path = fs::path(GLINT_SOURCE_DIR) / "tests/fuzz/corpus/exr/oom-rle-huge-lines.exr";
    ASSERT_LT(fs::file_size(path), 1024u);
    const std::string error = load_error_without_allocating(path);
    EXPECT_NE(error.find("damaged"), std::string::npos) << error;
    EXPECT_NE(error.find(path.string()), std::string::npos) << error;
}

TEST_F(ExrIo, TruncatedHeaderIsAnInputErrorNamingIt) {
    const fs::path path = dir_ / "header_only.exr";
    save_exr(path, pattern(64, 32));
    fs::resize_file(path, 40);
    expect_input_error_naming(path);
}

TEST_F(ExrIo, CorruptFileIsAnInputErrorNamingIt) {
    const fs::path path = dir_ / "corrupt.exr";
    std::mt19937 rng(7);
    std::string bytes(8192, '\0');
    for (char& c : bytes) c = char(rng() & 0xff);
    write_bytes(path, bytes);
    expect_input_error_naming(path);
}

TEST_F(ExrIo, EmptyFileIsAnInputErrorNamingIt) {
    const fs::path path = dir_ / "empty.exr";
    write_bytes(path, "");
    ASSERT_TRUE(fs::exists(path));
    expect_input_error_naming(path);
}

TEST_F(ExrIo, MissingFileIsAnInputErrorNamingIt) {
    expect_input_error_naming(dir_ / "no_such_file.exr");
}

TEST_F(ExrIo, DirectoryIsAnInputErrorNamingIt) { expect_input_error_naming(dir_); }

TEST_F(ExrIo, FileWithoutRgbOrYIsAnInputErrorNamingIt) {
    const fs::path depth = dir_ / "depth.exr";
    write_exr(depth, 4, 2, {{"Z", Imf::FLOAT}, {"A", Imf::HALF}},
              [](const std::string&, int, int) { return 1.0f; });
    expect_input_error_naming(depth);

    // R and G without B is not an RGB file either.
    const fs::path rg = dir_ / "rg.exr";
    write_exr(rg, 4, 2, {{"R", Imf::FLOAT}, {"G", Imf::FLOAT}},
              [](const std::string&, int, int) { return 1.0f; });
    expect_input_error_naming(rg);
}

TEST_F(ExrIo, SaveLeavesNoTempFiles) {
    save_exr(dir_ / "a.exr", pattern(16, 8));
    save_exr(dir_ / "a.exr", pattern(16, 8));
    save_exr(dir_ / "b.exr", pattern(8, 4));
    std::vector<std::string> names = listing();
    std::sort(names.begin(), names.end());
    EXPECT_EQ(names, (std::vector<std::string>{"a.exr", "b.exr"}));
}

TEST_F(ExrIo, SaveIntoAMissingDirectoryThrowsAndLeavesNothing) {
    const fs::path missing = dir_ / "missing";
    EXPECT_ANY_THROW(save_exr(missing / "out.exr", pattern(8, 4)));
    EXPECT_FALSE(fs::exists(missing));
    EXPECT_TRUE(listing().empty());
}

TEST_F(ExrIo, FailedSaveKeepsTheOldFile) {
    const fs::path path = dir_ / "keep.exr";
    const HdrImage old = pattern(8, 4);
    save_exr(path, old);
    EXPECT_ANY_THROW(save_exr(path, HdrImage()));  // an empty image cannot be saved
    EXPECT_EQ(load_exr(path).image.data(), old.data());
    EXPECT_EQ(listing(), std::vector<std::string>{"keep.exr"});
}

}  // namespace
}  // namespace glint
