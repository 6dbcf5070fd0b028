// The GPU engine against the CPU engine for the same plans (the issue's
// parity: within 1e-4 weighted relative RMS), on the three test maps and the
// hard cases; tiles that cover every texel once; cancellation.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <random>
#include <string>

#include "appliance/convolution/convolution.hpp"
#include "appliance/convolution/gpu/gpu_engine.hpp"
#include "appliance/convolution/mipmap.hpp"
#include "appliance/core/equirect.hpp"
#include "appliance/core/error_metrics.hpp"
#include "appliance/core/exr_io.hpp"
#include "gpu_fixture.hpp"

namespace glint::convolution::gpu {
namespace {

using test::GpuTest;

constexpr double kParity = 1e-4;

HdrImage smooth_map(int w, int h, unsigned seed) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<double> u(0.0, 1.0);
    const double a = 6 * u(rng), b = 6 * u(rng);
    HdrImage img(w, h);
    for (int j = 0; j < h; ++j)
        for (int i = 0; i < w; ++i) {
            const double t = row_theta(j, h), p = column_phi(i, w);
            const double v = 1.5 + 0.6 * std::sin(3 * p + a) * std::sin(t) + 0.3 * std::cos(5 * t + b);
            img.set(i, j, {float(v), float(0.7 * v + 0.1), float(1.3 * v)});
        }
    return img;
}

HdrImage bright_texel_map(int w, int h, int i, int j) {
    HdrImage img(w, h);
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) img.set(x, y, {0.01f, 0.01f, 0.01f});
    img.set(i, j, {1e5f, 1e5f, 1e5f});
    return img;
}

std::vector<MapRequest> requests(bool irradiance, const std::vector<double>& ns, Size size) {
    std::vector<MapRequest> r;
    if (irradiance) r.push_back(MapRequest::make_irradiance());
    for (double n : ns) {
        char text[32];
        std::snprintf(text, sizeof text, "%g", n);
        r.push_back(MapRequest::make_phong(n, text));
    }
    for (MapRequest& m : r) m.size = size;
    return r;
}

class GpuEngineTest : public GpuTest {
protected:
    // The CPU and GPU results of the same request (plans must agree).
    void expect_parity(const HdrImage& env, const std::vector<MapRequest>& maps, Method method, const char* what,
                       double limit = kParity) {
        Options o;
        o.method = method;
        o.threads = 2;
        const std::vector<MapResult> cpu = convolve(env, maps, o);
        UnlimitedGate gate(50.0);
        GpuEngine engine(context(), gate);
        o.executor = &engine;
        const std::vector<MapResult> gpu = convolve(env, maps, o);
        ASSERT_EQ(cpu.size(), gpu.size());
        for (std::size_t k = 0; k < cpu.size(); ++k) {
            ASSERT_EQ(cpu[k].plan.method, gpu[k].plan.method) << what << " " << cpu[k].request.label;
            const MapError e = compare_maps(gpu[k].image, cpu[k].image);
            std::printf("[  parity  ] %-28s %-7s %-12s rel_rms %.2e worst %.2e\n", what,
                        to_string(cpu[k].plan.method).c_str(), cpu[k].request.label.c_str(), e.weighted_relative_rms,
                        e.worst_texel);
            EXPECT_LE(e.weighted_relative_rms, limit) << what << " " << cpu[k].request.label;
            for (float v : gpu[k].image.data()) ASSERT_TRUE(std::isfinite(v)) << what << " " << cpu[k].request.label;
        }
    }
};

TEST_F(GpuEngineTest, ExactMatchesTheCpuForEightMapsInOnePass) {
    const HdrImage env = smooth_map(64, 32, 3);
    expect_parity(env, requests(true, {0, 1, 5, 20, 80, 160, 1280}, {32, 16}), Method::Exact, "exact 64x32");
}

TEST_F(GpuEngineTest, ConeMatchesTheCpuOnTheTestMaps) {
    for (const char* name : {"courtyard", "studio", "sunset"}) {
        const std::filesystem::path path = std::filesystem::path(GLINT_BLENDER_WORLDS) / (std::string(name) + ".exr");
        ASSERT_TRUE(std::filesystem::exists(path)) << path << " (Debian package blender-data)";
        // Level 2 of the map (256x128) keeps llvmpipe's time in seconds.
        const Pyramid pyramid(load_exr(path).image);
        const HdrImage env = pyramid.level(2);
        expect_parity(env, requests(true, {20, 160, 1280, 5120}, {128, 64}), Method::Cone, name);
    }
}

TEST_F(GpuEngineTest, AutoMatchesTheCpuOnCourtyard) {
    const Pyramid pyramid(load_exr(std::filesystem::path(GLINT_BLENDER_WORLDS) / "courtyard.exr").image);
    expect_parity(pyramid.level(2), requests(true, {10, 160, 5120, 20480}, {128, 64}), Method::Auto, "auto courtyard");
}

// A 1024x512 input: more texels than one shader loop may run on llvmpipe
// (65535 iterations), so the passes must split the input rows into bands.
TEST_F(GpuEngineTest, FullSizeInputSumsEveryRow) {
    const HdrImage env = load_exr(std::filesystem::path(GLINT_BLENDER_WORLDS) / "courtyard.exr").image;
    expect_parity(env, requests(true, {20}, {16, 8}), Method::Exact, "exact courtyard 1024x512");
    expect_parity(env, requests(false, {5120}, {64, 32}), Method::Cone, "cone courtyard 1024x512");
}

// Rows near the poles merge columns only where their values are smooth (polar_merge_factors):
// a smooth northern half merges, log-normal noise in the southern one does not, and both
// engines read each row with the same factor.
TEST_F(GpuEngineTest, RoughAndSmoothPolarRowsMatchTheCpu) {
    HdrImage env = smooth_map(256, 128, 5);
    std::mt19937 rng(11);
    std::normal_distribution<double> gauss(0.0, 1.0);
    for (int j = 64; j < 128; ++j)
        for (int i = 0; i < 256; ++i) {
            const float v = float(std::exp(2.0 * gauss(rng)));
            env.set(i, j, {v, 0.8f * v, 0.6f * v});
        }
    expect_parity(env, requests(false, {1280, 5120}, {128, 64}), Method::Cone, "smooth north, rough south");
}

TEST_F(GpuEngineTest, BrightTexelAtThePoleTheSeamAndInsideMatchesTheCpu) {
    const struct {
        const char* name;
        int i, j;
    } cases[] = {{"bright texel inside", 37, 21}, {"bright texel top row", 50, 0}, {"bright texel column 0", 0, 40}};
    for (const auto& c : cases)
        expect_parity(bright_texel_map(128, 64, c.i, c.j), requests(true, {20, 160, 1280}, {64, 32}), Method::Cone,
                      c.name);
}

// Float accumulation: the constant to 1e-5 (the CPU engine, in double, to 1e-6).
TEST_F(GpuEngineTest, ConstantMapGivesTheConstant) {
    HdrImage env(64, 32);
    for (int j = 0; j < 32; ++j)
        for (int i = 0; i < 64; ++i) env.set(i, j, {0.25f, 2.0f, 7.5f});
    UnlimitedGate gate(50.0);
    GpuEngine engine(context(), gate);
    for (Method method : {Method::Exact, Method::Cone}) {
        Options o;
        o.method = method;
        o.executor = &engine;
        for (const MapResult& r : convolve(env, requests(true, {0, 20, 20480}, {32, 16}), o))
            for (int j = 0; j < 16; ++j)
                for (int i = 0; i < 32; ++i) {
                    const Rgb v = r.image.at(i, j);
                    ASSERT_NEAR(v.r, 0.25, 0.25 * 1e-5) << to_string(method) << " " << r.request.label;
                    ASSERT_NEAR(v.g, 2.0, 2.0 * 1e-5) << to_string(method) << " " << r.request.label;
                    ASSERT_NEAR(v.b, 7.5, 7.5 * 1e-5) << to_string(method) << " " << r.request.label;
                }
    }
}

// The rest of the CPU issue's hard cases: a dynamic range of 1e-6 .. 6e4 in one
// map, a map lit only from below, an all-zero map.
TEST_F(GpuEngineTest, DynamicRangeLitFromBelowAndZeroMapsMatchTheCpu) {
    HdrImage range(128, 64), below(128, 64), zero(128, 64);
    std::mt19937 rng(11);
    std::uniform_real_distribution<double> u(0.0, 1.0);
    for (int j = 0; j < 64; ++j)
        for (int i = 0; i < 128; ++i) {
            const float v = float(std::pow(10.0, -6.0 + 10.78 * u(rng)));  // 1e-6 .. 6e4
            range.set(i, j, {v, 0.5f * v, 2.0f * v});
            const float b = j >= 32 ? 1.0f + 0.01f * float(i % 7) : 0.0f;  // the lower hemisphere only
            below.set(i, j, {b, b, b});
        }
    for (Method m : {Method::Cone, Method::Auto}) {
        expect_parity(range, requests(true, {20, 160, 1280}, {64, 32}), m, "dynamic range 1e-6..6e4");
        expect_parity(below, requests(true, {20, 160}, {64, 32}), m, "lit only from below");
    }
    UnlimitedGate gate(50.0);
    GpuEngine engine(context(), gate);
    Options o;
    o.method = Method::Cone;
    o.executor = &engine;
    for (const MapResult& r : convolve(zero, requests(true, {20, 20480}, {32, 16}), o))
        for (float v : r.image.data()) ASSERT_EQ(v, 0.0f) << r.request.label;
}

TEST_F(GpuEngineTest, TinyMapWithHugeShininessGivesTheNearestTexelsNeverNan) {
    const HdrImage env = smooth_map(8, 4, 9);
    expect_parity(env, requests(false, {20480}, {8, 4}), Method::Exact, "8x4 n=20480");
    expect_parity(env, requests(false, {20480}, {8, 4}), Method::Cone, "8x4 n=20480");
}

TEST_F(GpuEngineTest, ShReconstructionMatchesTheCpu) {
    const HdrImage env = smooth_map(128, 64, 8);
    expect_parity(env, requests(true, {10, 40, 160}, {64, 32}), Method::Sh, "sh");
    const Pyramid pyramid(load_exr(std::filesystem::path(GLINT_BLENDER_WORLDS) / "sunset.exr").image);
    expect_parity(pyramid.level(1), requests(false, {640, 1280}, {128, 64}), Method::Auto, "auto sunset (sh split)");
}

TEST_F(GpuEngineTest, MipmapMatchesTheCpu) {
    const HdrImage env = smooth_map(128, 64, 4);
    expect_parity(env, requests(true, {1, 10, 40, 160, 640}, {64, 32}), Method::Mipmap, "mipmap", 1e-6);
}

// A hard cap far below one draw's time splits the pass into many tiles;
// every texel is drawn once, so the result is the one-draw result exactly.
TEST_F(GpuEngineTest, TilesCoverEveryTexelOnce) {
    const HdrImage env = smooth_map(64, 32, 5);
    const std::vector<MapRequest> maps = requests(false, {20, 160}, {48, 24});
    Options o;
    o.method = Method::Exact;
    UnlimitedGate big(1e6), tiny(1e-4);
    GpuEngine one(context(), big, 1e6), many(context(), tiny, 1e-4);
    o.executor = &one;
    const auto a = convolve(env, maps, o);
    o.executor = &many;
    const auto b = convolve(env, maps, o);
    EXPECT_GT(many.stats().tiles, 100) << "a tiny cap must split the pass";
    EXPECT_LT(one.stats().tiles, many.stats().tiles / 10);
    for (std::size_t k = 0; k < a.size(); ++k) EXPECT_EQ(a[k].image.data(), b[k].image.data()) << k;
}

// A gate that cancels after a few tiles: the job unwinds with JobCancelled and
// the textures it made are gone; the engine then runs a new job.
class CancellingGate final : public TileGate {
public:
    explicit CancellingGate(int tiles) : left_(tiles) {}
    double acquire() override {
        if (left_-- <= 0) throw JobCancelled();
        return 1e-4;
    }
    void spent(double) override {}

private:
    int left_;
};

TEST_F(GpuEngineTest, CancelledJobReleasesItsGlObjectsAndARestartWorks) {
    const HdrImage env = smooth_map(64, 32, 6);
    const std::vector<MapRequest> maps = requests(false, {40}, {32, 16});
    GLuint before = 0;
    glGenTextures(1, &before);
    glDeleteTextures(1, &before);
    CancellingGate gate(5);
    GpuEngine engine(context(), gate, 1e-4);
    Options o;
    o.method = Method::Exact;
    o.executor = &engine;
    EXPECT_THROW(convolve(env, maps, o), JobCancelled);
    for (GLuint name = before; name < before + 64; ++name) EXPECT_FALSE(glIsTexture(name)) << name;
    UnlimitedGate open(50.0);
    GpuEngine again(context(), open);
    o.executor = &again;
    const auto r = convolve(env, maps, o);
    ASSERT_EQ(r.size(), 1u);
    EXPECT_GT(r[0].image.at(5, 5).r, 0.0f);
}

}  // namespace
}  // namespace glint::convolution::gpu

namespace glint::convolution::gpu {
namespace {

TEST_F(GpuEngineTest, FineTilesMatchTheCpusOnTheSamePlans) {
    // Options::fine_tiles (docs/convolution.md, "Fine tiles") with the sums on the GPU: the same
    // tiles as the CPU engine's, and their texels and the sum grid within the parity.
    HdrImage env = smooth_map(128, 64, 9);
    env.set(40, 20, {3e4f, 2e4f, 1e4f});
    std::vector<MapRequest> maps;
    for (double n : {300.0, 2000.0}) maps.push_back(MapRequest::make_phong(n, std::to_string(int(n))));
    Options o;
    o.threads = 2;
    o.fine_tiles = true;
    const std::vector<MapResult> cpu = convolve(env, maps, o);
    UnlimitedGate gate(50.0);
    GpuEngine engine(context(), gate);
    o.executor = &engine;
    const std::vector<MapResult> gpu = convolve(env, maps, o);
    int tiled = 0;
    for (std::size_t k = 0; k < cpu.size(); ++k) {
        const std::string what = cpu[k].request.label;
        ASSERT_EQ(cpu[k].fine.slot, gpu[k].fine.slot) << what;
        if (cpu[k].fine.empty()) continue;
        ++tiled;
        const MapError base = compare_maps(gpu[k].image, cpu[k].image);
        const MapError blocks = compare_maps(gpu[k].fine.blocks, cpu[k].fine.blocks);
        std::printf("[  parity  ] fine tiles %-10s %d tiles: sum grid %.2e, tiles %.2e\n", what.c_str(),
                    cpu[k].fine.count(), base.weighted_relative_rms, blocks.weighted_relative_rms);
        EXPECT_LE(base.weighted_relative_rms, kParity) << what;
        EXPECT_LE(blocks.weighted_relative_rms, kParity) << what;
    }
    EXPECT_GE(tiled, 1);
}

}  // namespace
}  // namespace glint::convolution::gpu
