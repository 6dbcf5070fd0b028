// Ambient occlusion baked with Embree (appliance/render/ao_bake.hpp) and its file (ao_file.hpp).
//
// Monte Carlo tolerance: a vertex's ao is the fraction of N cosine-weighted rays that escape. Were
// the rays independent, its standard deviation would be sqrt(p (1 - p) / N): 0.0078 at most for
// N = 4096. The tests allow about 4 of those where the expected value is not 0 or 1; the
// stratified (shifted Hammersley) rays the bake uses do better than independent ones.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <fstream>

#include "appliance/core/errors.hpp"
#include "appliance/render/ao_bake.hpp"
#include "appliance/render/ao_file.hpp"
#include "appliance/render/teapot.hpp"
#include "test_support.hpp"

namespace glint::render {
namespace {

constexpr int kRays = 4096;

// A quad (a, b, c, d counter-clockwise seen from the side `n` points to) as two triangles.
void add_quad(Mesh& m, glm::vec3 a, glm::vec3 b, glm::vec3 c, glm::vec3 d, glm::vec3 n) {
    const auto base = std::uint32_t(m.positions.size());
    for (const auto& p : {a, b, c, d}) {
        m.positions.push_back(p);
        m.normals.push_back(n);
    }
    m.indices.insert(m.indices.end(), {base, base + 1, base + 2, base, base + 2, base + 3});
}

// A vertex used by no triangle: the bake still gives it a value, which is how the tests place a
// probe exactly where they want with the normal they want.
std::size_t add_probe(Mesh& m, glm::vec3 p, glm::vec3 n) {
    m.positions.push_back(p);
    m.normals.push_back(glm::normalize(n));
    return m.positions.size() - 1;
}

AoBakeOptions options(double max_distance_relative) {
    AoBakeOptions o;
    o.rays = kRays;
    o.max_distance_relative = max_distance_relative;
    return o;
}

TEST(AoBake, CosineDirectionsAreCosineDistributed) {
    // E[cos] = 2/3 and E[cos^2] = 1/2 under the density cos / pi on the hemisphere.
    double c1 = 0, c2 = 0;
    for (int k = 0; k < kRays; ++k) {
        double d[3];
        cosine_direction(k, kRays, 0.3, 0.7, d);
        ASSERT_NEAR(d[0] * d[0] + d[1] * d[1] + d[2] * d[2], 1.0, 1e-12);
        ASSERT_GE(d[2], 0.0);
        c1 += d[2];
        c2 += d[2] * d[2];
    }
    EXPECT_NEAR(c1 / kRays, 2.0 / 3.0, 1e-3);
    EXPECT_NEAR(c2 / kRays, 0.5, 1e-3);
}

TEST(AoBake, OpenPlaneIsUnoccluded) {
    Mesh m;
    add_quad(m, {-1, 0, 1}, {1, 0, 1}, {1, 0, -1}, {-1, 0, -1}, {0, 1, 0});
    const std::size_t centre = add_probe(m, {0, 0, 0}, {0, 1, 0});
    const auto ao = bake_ambient_occlusion(m, options(0.5));
    ASSERT_EQ(ao.size(), m.positions.size());
    for (float a : ao) EXPECT_EQ(a, 1.0f);  // nothing is above the plane: every ray escapes
    EXPECT_EQ(ao[centre], 1.0f);
}

// A closed cube seen from inside (its normals point in): every ray from the floor's centre hits a
// wall within the diagonal.
TEST(AoBake, InsideAClosedBoxIsBlack) {
    Mesh m;
    const float s = 1;
    add_quad(m, {-s, -s, -s}, {s, -s, -s}, {s, -s, s}, {-s, -s, s}, {0, 1, 0});   // floor
    add_quad(m, {-s, s, -s}, {-s, s, s}, {s, s, s}, {s, s, -s}, {0, -1, 0});     // ceiling
    add_quad(m, {-s, -s, -s}, {-s, s, -s}, {s, s, -s}, {s, -s, -s}, {0, 0, 1});   // back
    add_quad(m, {-s, -s, s}, {s, -s, s}, {s, s, s}, {-s, s, s}, {0, 0, -1});      // front
    add_quad(m, {-s, -s, -s}, {-s, -s, s}, {-s, s, s}, {-s, s, -s}, {1, 0, 0});   // left
    add_quad(m, {s, -s, -s}, {s, s, -s}, {s, s, s}, {s, -s, s}, {-1, 0, 0});      // right
    const std::size_t probe = add_probe(m, {0.1f, -s, -0.2f}, {0, 1, 0});
    const auto ao = bake_ambient_occlusion(m, options(2.0));  // 2 x radius sqrt(3): beyond any wall
    EXPECT_EQ(ao[probe], 0.0f);
    // With a short reach (0.5 x sqrt(3) = 0.87, less than the height 2) most of the ceiling is
    // beyond it: what a limit does to a vessel's inside.
    EXPECT_GT(bake_ambient_occlusion(m, options(0.5))[probe], 0.2f);
}

// The bottom of a square well (side a = 1, depth h = 2, no lid): it sees the sky through the
// opening only. The cosine-weighted fraction is the form factor from a point to a parallel square
// centred above it: four corner rectangles of X = Y = (a/2)/h,
//   F = 4 / (2 pi) * 2 * X / sqrt(1 + X^2) * atan(X / sqrt(1 + X^2))       = 0.07348 for X = 1/4.
TEST(AoBake, BottomOfAWellSeesItsOpening) {
    Mesh m;
    const float a = 0.5f, h = 2;
    add_quad(m, {-a, 0, -a}, {a, 0, -a}, {a, 0, a}, {-a, 0, a}, {0, 1, 0});
    add_quad(m, {-a, 0, -a}, {-a, h, -a}, {a, h, -a}, {a, 0, -a}, {0, 0, 1});
    add_quad(m, {-a, 0, a}, {a, 0, a}, {a, h, a}, {-a, h, a}, {0, 0, -1});
    add_quad(m, {-a, 0, -a}, {-a, 0, a}, {-a, h, a}, {-a, h, -a}, {1, 0, 0});
    add_quad(m, {a, 0, -a}, {a, h, -a}, {a, h, a}, {a, 0, a}, {-1, 0, 0});
    const std::size_t probe = add_probe(m, {0, 0, 0}, {0, 1, 0});
    const double x = 0.25, q = x / std::sqrt(1 + x * x);
    const double expected = 4.0 / (2.0 * 3.14159265358979323846) * 2.0 * q * std::atan(q);
    ASSERT_NEAR(expected, 0.07348, 1e-5);
    const auto ao = bake_ambient_occlusion(m, options(10.0));
    std::printf("well: ao %.5f, analytic %.5f\n", ao[probe], expected);
    EXPECT_NEAR(ao[probe], expected, 0.016);  // 4 sigma of independent rays: sqrt(0.073 * 0.927 / 4096) = 0.0041
}

// The inner edge of a 90 degree wedge (floor y = 0, wall z = 0, open towards +y +z), normal along
// the bisector n = (0, 1, 1) / sqrt 2. The open directions are the quarter space Q = {y > 0, z > 0},
// all inside n's hemisphere, so
//   ao = (1/pi) integral_Q n.d dw = (1/pi) n . (0, pi/2, pi/2) = 1 / sqrt 2 = 0.7071
// (the integral of d_y over the upper hemisphere is pi, and half of it has z > 0). It holds for
// any point inside Q, so the bake's offset off the surface does not change it.
TEST(AoBake, InsideCornerOfTwoPlanesIsOneOverRootTwo) {
    Mesh m;
    const float l = 50;
    add_quad(m, {-l, 0, 0}, {-l, 0, l}, {l, 0, l}, {l, 0, 0}, {0, 1, 0});  // floor, z in [0, l]
    add_quad(m, {-l, 0, 0}, {l, 0, 0}, {l, l, 0}, {-l, l, 0}, {0, 0, 1});  // wall, y in [0, l]
    const std::size_t probe = add_probe(m, {0, 0, 0}, {0, 1, 1});
    const auto ao = bake_ambient_occlusion(m, options(10.0));
    std::printf("wedge: ao %.5f, analytic %.5f\n", ao[probe], 1.0 / std::sqrt(2.0));
    EXPECT_NEAR(ao[probe], 1.0 / std::sqrt(2.0), 0.03);  // 4 sigma: sqrt(0.707 * 0.293 / 4096) = 0.0071
    // The floor alone: open.
    Mesh one_plane;
    add_quad(one_plane, {-l, 0, 0}, {-l, 0, l}, {l, 0, l}, {l, 0, 0}, {0, 1, 0});
    const std::size_t lone = add_probe(one_plane, {0, 0, 10}, {0, 1, 0});
    EXPECT_EQ(bake_ambient_occlusion(one_plane, options(10.0))[lone], 1.0f);
}

TEST(AoBake, DuplicatedVerticesGetTheSameValueAndProgressReachesTheTotal) {
    Mesh m;
    const float l = 50;
    add_quad(m, {-l, 0, 0}, {-l, 0, l}, {l, 0, l}, {l, 0, 0}, {0, 1, 0});
    add_quad(m, {-l, 0, 0}, {l, 0, 0}, {l, l, 0}, {-l, l, 0}, {0, 0, 1});
    const std::size_t a = add_probe(m, {1, 0, 0}, {0, 1, 1});
    const std::size_t b = add_probe(m, {1, 0, 0}, {0, 1, 1});
    const std::size_t c = add_probe(m, {2, 0, 0}, {0, 1, 1});
    AoBakeOptions o = options(10.0);
    o.rays = 64;
    std::size_t last = 0, total = 0;
    o.progress = [&](std::size_t done, std::size_t all) {
        last = std::max(last, done);
        total = all;
    };
    const auto ao = bake_ambient_occlusion(m, o);
    EXPECT_EQ(ao[a], ao[b]);
    EXPECT_NEAR(ao[c], 1.0 / std::sqrt(2.0), 0.25);  // another point of the edge: another seed, about the same value
    EXPECT_EQ(last, m.positions.size());
    EXPECT_EQ(total, m.positions.size());
}

TEST(AoBake, RejectsBadInput) {
    Mesh empty;
    EXPECT_THROW(bake_ambient_occlusion(empty), InputError);
    Mesh m;
    add_quad(m, {-1, 0, 1}, {1, 0, 1}, {1, 0, -1}, {-1, 0, -1}, {0, 1, 0});
    AoBakeOptions o;
    o.rays = 0;
    EXPECT_THROW(bake_ambient_occlusion(m, o), InputError);
    o.rays = 8;
    o.max_distance_relative = 0;
    EXPECT_THROW(bake_ambient_occlusion(m, o), InputError);
}

TEST(AoBake, TeapotFieldResamplesInEachPatch) {
    // A field linear in each patch's (u, v) is reproduced exactly; the same level is the identity.
    const int from = 4, to = 10;
    std::vector<float> field;
    for (int p = 0; p < 32; ++p)
        for (int i = 0; i <= from; ++i)
            for (int j = 0; j <= from; ++j) field.push_back(float(p) + 0.25f * float(i) / from + 0.5f * float(j) / from);
    const auto fine = resample_teapot_field(field, from, to);
    ASSERT_EQ(fine.size(), std::size_t(32 * (to + 1) * (to + 1)));
    for (int p = 0; p < 32; ++p)
        for (int i = 0; i <= to; ++i)
            for (int j = 0; j <= to; ++j)
                ASSERT_NEAR(fine[std::size_t((p * (to + 1) + i) * (to + 1) + j)],
                            float(p) + 0.25f * float(i) / to + 0.5f * float(j) / to, 1e-5f);
    EXPECT_EQ(resample_teapot_field(field, from, from), field);
    EXPECT_THROW(resample_teapot_field(field, from + 1, to), InputError);
}

// What glint render does for a teapot finer than level 16: bake the coarse one, resample. Against
// a bake of the fine one itself (here 8 -> 24, 128 rays, so that the test stays short).
TEST(AoBake, ResampledTeapotBakeIsCloseToADirectOne) {
    AoBakeOptions o;
    o.rays = 128;
    Mesh coarse = make_teapot(8), fine = make_teapot(24);
    normalise_to_unit_sphere(coarse);
    normalise_to_unit_sphere(fine);
    const auto resampled = resample_teapot_field(bake_ambient_occlusion(coarse, o), 8, 24);
    const auto direct = bake_ambient_occlusion(fine, o);
    double sum = 0, worst = 0, mean = 0;
    for (std::size_t k = 0; k < direct.size(); ++k) {
        const double d = std::abs(double(resampled[k]) - double(direct[k]));
        sum += d;
        worst = std::max(worst, d);
        mean += direct[k];
    }
    std::printf("teapot ao, level 8 resampled to 24 against 24 baked: mean |diff| %.4f, worst %.4f (mean ao %.3f)\n",
                sum / double(direct.size()), worst, mean / double(direct.size()));
    EXPECT_LT(sum / double(direct.size()), 0.03);
    EXPECT_GT(mean / double(direct.size()), 0.5);  // the teapot is mostly open...
    EXPECT_LT(mean / double(direct.size()), 0.95);  // ...but its inside, spout and handle are not
}

class AoFileTest : public testing::TempDirTest {};

TEST_F(AoFileTest, RoundTripAndStaleDetection) {
    const auto model = dir_ / "quad.obj";
    {
        std::ofstream out(model);
        out << "v 0 0 0\nv 1 0 0\nv 1 1 0\nf 1 2 3\n";
    }
    AoFile f;
    f.model_name = "quad.obj";
    f.model_checksum = file_checksum(model, &f.model_bytes);
    f.rays = 64;
    f.max_distance_relative = 0.5;
    f.ao = {0.25f, 0.5f, 1.0f};
    const auto path = ao_path_for(model);
    EXPECT_EQ(path.filename(), "quad.obj.ao");
    save_ao_file(path, f);
    const AoFile g = load_ao_file(path);
    EXPECT_EQ(g.ao, f.ao);
    EXPECT_EQ(g.model_checksum, f.model_checksum);
    EXPECT_EQ(g.model_bytes, 32u);
    EXPECT_EQ(g.rays, 64);

    AoLookup ok = find_ao_for(model, 3);
    EXPECT_TRUE(ok.used) << ok.status;
    EXPECT_EQ(ok.ao, f.ao);
    // Another vertex count: stale.
    AoLookup count = find_ao_for(model, 4);
    EXPECT_TRUE(count.found);
    EXPECT_FALSE(count.used);
    EXPECT_NE(count.status.find("stale"), std::string::npos) << count.status;
    // The model edited after the bake (same size, other bytes): stale.
    {
        std::ofstream out(model);
        out << "v 0 0 0\nv 2 0 0\nv 1 1 0\nf 1 2 3\n";
    }
    AoLookup edited = find_ao_for(model, 3);
    EXPECT_FALSE(edited.used);
    EXPECT_NE(edited.status.find("stale"), std::string::npos) << edited.status;
    // No file: not found, nothing used.
    std::filesystem::remove(path);
    AoLookup none = find_ao_for(model, 3);
    EXPECT_FALSE(none.found);
    EXPECT_FALSE(none.used);
}

TEST_F(AoFileTest, CorruptFilesAreRejectedNamingTheFile) {
    AoFile f;
    f.model_name = "m.obj";
    f.ao = {0.5f, 0.75f};
    const auto path = dir_ / "m.obj.ao";
    save_ao_file(path, f);
    std::string bytes;
    {
        std::ifstream in(path, std::ios::binary);
        bytes.assign(std::istreambuf_iterator<char>(in), {});
    }
    const auto write = [&](const std::string& b) {
        std::ofstream out(path, std::ios::binary | std::ios::trunc);
        out << b;
    };
    const auto expect_bad = [&](const std::string& b, const std::string& needle) {
        write(b);
        try {
            load_ao_file(path);
            ADD_FAILURE() << "accepted a file that should fail with " << needle;
        } catch (const InputError& e) {
            EXPECT_NE(std::string(e.what()).find(path.string()), std::string::npos) << e.what();
            EXPECT_NE(std::string(e.what()).find(needle), std::string::npos) << e.what();
        }
    };
    std::string flipped = bytes;
    flipped[flipped.size() - 1] ^= 0x01;  // a bit of the last float
    expect_bad(flipped, "checksum");
    expect_bad(bytes.substr(0, bytes.size() - 2), "short");
    // A vertex count far beyond the data is refused before anything is allocated for it (it asked
    // for 16 GiB before; tests/fuzz/corpus/ao/oom-vertex-count.ao).
    std::string huge = bytes;
    huge.replace(huge.find("vertices 2"), 10, "vertices 4294967296");
    expect_bad(huge, "the header says 4294967296 vertices (17179869184 bytes), 8 bytes follow it");
    expect_bad("glint-ao 2\n" + bytes.substr(bytes.find('\n') + 1), "not a glint ao file");
    expect_bad(bytes + "x", "after the data");
    std::string no_rays = bytes;
    no_rays.erase(no_rays.find("rays "), no_rays.find('\n', no_rays.find("rays ")) - no_rays.find("rays ") + 1);
    expect_bad(no_rays, "'rays'");
}

}  // namespace
}  // namespace glint::render
