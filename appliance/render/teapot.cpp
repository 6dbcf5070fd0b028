#include "appliance/render/teapot.hpp"

#include <algorithm>
#include <cmath>
#include <string>

#include "appliance/core/errors.hpp"

namespace glint::render {
namespace {

// Newell's teapot, Z up: 306 control points. Public domain (Martin Newell, University of Utah,
// 1975); the set as published in Crow, "The Origins of the Teapot", IEEE CG&A 7(1), 1987, and
// copied unchanged into many programs since (compared with Steve Baker's `teaset` copy: identical). Four of the points (205, 206, 216 and 223 in the
// original 1-based numbering: the knob's top nudged off the axis by 0.002) are used by no patch of
// this set, whose knob patches collapse to point 204 instead; they are kept so that the numbering
// stays the original's. Mirror-symmetric in y (tested).
const std::array<glm::dvec3, 306> kPoints = {{
    {1.4, 0.0, 2.4}, {1.4, -0.784, 2.4}, {0.784, -1.4, 2.4}, {0.0, -1.4, 2.4},
    {1.3375, 0.0, 2.53125}, {1.3375, -0.749, 2.53125}, {0.749, -1.3375, 2.53125}, {0.0, -1.3375, 2.53125},
    {1.4375, 0.0, 2.53125}, {1.4375, -0.805, 2.53125}, {0.805, -1.4375, 2.53125}, {0.0, -1.4375, 2.53125},
    {1.5, 0.0, 2.4}, {1.5, -0.84, 2.4}, {0.84, -1.5, 2.4}, {0.0, -1.5, 2.4},
    {-0.784, -1.4, 2.4}, {-1.4, -0.784, 2.4}, {-1.4, 0.0, 2.4}, {-0.749, -1.3375, 2.53125},
    {-1.3375, -0.749, 2.53125}, {-1.3375, 0.0, 2.53125}, {-0.805, -1.4375, 2.53125}, {-1.4375, -0.805, 2.53125},
    {-1.4375, 0.0, 2.53125}, {-0.84, -1.5, 2.4}, {-1.5, -0.84, 2.4}, {-1.5, 0.0, 2.4},
    {-1.4, 0.784, 2.4}, {-0.784, 1.4, 2.4}, {0.0, 1.4, 2.4}, {-1.3375, 0.749, 2.53125},
    {-0.749, 1.3375, 2.53125}, {0.0, 1.3375, 2.53125}, {-1.4375, 0.805, 2.53125}, {-0.805, 1.4375, 2.53125},
    {0.0, 1.4375, 2.53125}, {-1.5, 0.84, 2.4}, {-0.84, 1.5, 2.4}, {0.0, 1.5, 2.4},
    {0.784, 1.4, 2.4}, {1.4, 0.784, 2.4}, {0.749, 1.3375, 2.53125}, {1.3375, 0.749, 2.53125},
    {0.805, 1.4375, 2.53125}, {1.4375, 0.805, 2.53125}, {0.84, 1.5, 2.4}, {1.5, 0.84, 2.4},
    {1.75, 0.0, 1.875}, {1.75, -0.98, 1.875}, {0.98, -1.75, 1.875}, {0.0, -1.75, 1.875},
    {2.0, 0.0, 1.35}, {2.0, -1.12, 1.35}, {1.12, -2.0, 1.35}, {0.0, -2.0, 1.35},
    {2.0, 0.0, 0.9}, {2.0, -1.12, 0.9}, {1.12, -2.0, 0.9}, {0.0, -2.0, 0.9},
    {-0.98, -1.75, 1.875}, {-1.75, -0.98, 1.875}, {-1.75, 0.0, 1.875}, {-1.12, -2.0, 1.35},
    {-2.0, -1.12, 1.35}, {-2.0, 0.0, 1.35}, {-1.12, -2.0, 0.9}, {-2.0, -1.12, 0.9},
    {-2.0, 0.0, 0.9}, {-1.75, 0.98, 1.875}, {-0.98, 1.75, 1.875}, {0.0, 1.75, 1.875},
    {-2.0, 1.12, 1.35}, {-1.12, 2.0, 1.35}, {0.0, 2.0, 1.35}, {-2.0, 1.12, 0.9},
    {-1.12, 2.0, 0.9}, {0.0, 2.0, 0.9}, {0.98, 1.75, 1.875}, {1.75, 0.98, 1.875},
    {1.12, 2.0, 1.35}, {2.0, 1.12, 1.35}, {1.12, 2.0, 0.9}, {2.0, 1.12, 0.9},
    {2.0, 0.0, 0.45}, {2.0, -1.12, 0.45}, {1.12, -2.0, 0.45}, {0.0, -2.0, 0.45},
    {1.5, 0.0, 0.225}, {1.5, -0.84, 0.225}, {0.84, -1.5, 0.225}, {0.0, -1.5, 0.225},
    {1.5, 0.0, 0.15}, {1.5, -0.84, 0.15}, {0.84, -1.5, 0.15}, {0.0, -1.5, 0.15},
    {-1.12, -2.0, 0.45}, {-2.0, -1.12, 0.45}, {-2.0, 0.0, 0.45}, {-0.84, -1.5, 0.225},
    {-1.5, -0.84, 0.225}, {-1.5, 0.0, 0.225}, {-0.84, -1.5, 0.15}, {-1.5, -0.84, 0.15},
    {-1.5, 0.0, 0.15}, {-2.0, 1.12, 0.45}, {-1.12, 2.0, 0.45}, {0.0, 2.0, 0.45},
    {-1.5, 0.84, 0.225}, {-0.84, 1.5, 0.225}, {0.0, 1.5, 0.225}, {-1.5, 0.84, 0.15},
    {-0.84, 1.5, 0.15}, {0.0, 1.5, 0.15}, {1.12, 2.0, 0.45}, {2.0, 1.12, 0.45},
    {0.84, 1.5, 0.225}, {1.5, 0.84, 0.225}, {0.84, 1.5, 0.15}, {1.5, 0.84, 0.15},
    {-1.6, 0.0, 2.025}, {-1.6, -0.3, 2.025}, {-1.5, -0.3, 2.25}, {-1.5, 0.0, 2.25},
    {-2.3, 0.0, 2.025}, {-2.3, -0.3, 2.025}, {-2.5, -0.3, 2.25}, {-2.5, 0.0, 2.25},
    {-2.7, 0.0, 2.025}, {-2.7, -0.3, 2.025}, {-3.0, -0.3, 2.25}, {-3.0, 0.0, 2.25},
    {-2.7, 0.0, 1.8}, {-2.7, -0.3, 1.8}, {-3.0, -0.3, 1.8}, {-3.0, 0.0, 1.8},
    {-1.5, 0.3, 2.25}, {-1.6, 0.3, 2.025}, {-2.5, 0.3, 2.25}, {-2.3, 0.3, 2.025},
    {-3.0, 0.3, 2.25}, {-2.7, 0.3, 2.025}, {-3.0, 0.3, 1.8}, {-2.7, 0.3, 1.8},
    {-2.7, 0.0, 1.575}, {-2.7, -0.3, 1.575}, {-3.0, -0.3, 1.35}, {-3.0, 0.0, 1.35},
    {-2.5, 0.0, 1.125}, {-2.5, -0.3, 1.125}, {-2.65, -0.3, 0.9375}, {-2.65, 0.0, 0.9375},
    {-2.0, -0.3, 0.9}, {-1.9, -0.3, 0.6}, {-1.9, 0.0, 0.6}, {-3.0, 0.3, 1.35},
    {-2.7, 0.3, 1.575}, {-2.65, 0.3, 0.9375}, {-2.5, 0.3, 1.125}, {-1.9, 0.3, 0.6},
    {-2.0, 0.3, 0.9}, {1.7, 0.0, 1.425}, {1.7, -0.66, 1.425}, {1.7, -0.66, 0.6},
    {1.7, 0.0, 0.6}, {2.6, 0.0, 1.425}, {2.6, -0.66, 1.425}, {3.1, -0.66, 0.825},
    {3.1, 0.0, 0.825}, {2.3, 0.0, 2.1}, {2.3, -0.25, 2.1}, {2.4, -0.25, 2.025},
    {2.4, 0.0, 2.025}, {2.7, 0.0, 2.4}, {2.7, -0.25, 2.4}, {3.3, -0.25, 2.4},
    {3.3, 0.0, 2.4}, {1.7, 0.66, 0.6}, {1.7, 0.66, 1.425}, {3.1, 0.66, 0.825},
    {2.6, 0.66, 1.425}, {2.4, 0.25, 2.025}, {2.3, 0.25, 2.1}, {3.3, 0.25, 2.4},
    {2.7, 0.25, 2.4}, {2.8, 0.0, 2.475}, {2.8, -0.25, 2.475}, {3.525, -0.25, 2.49375},
    {3.525, 0.0, 2.49375}, {2.9, 0.0, 2.475}, {2.9, -0.15, 2.475}, {3.45, -0.15, 2.5125},
    {3.45, 0.0, 2.5125}, {2.8, 0.0, 2.4}, {2.8, -0.15, 2.4}, {3.2, -0.15, 2.4},
    {3.2, 0.0, 2.4}, {3.525, 0.25, 2.49375}, {2.8, 0.25, 2.475}, {3.45, 0.15, 2.5125},
    {2.9, 0.15, 2.475}, {3.2, 0.15, 2.4}, {2.8, 0.15, 2.4}, {0.0, 0.0, 3.15},
    {0.0, -0.002, 3.15}, {0.002, 0.0, 3.15}, {0.8, 0.0, 3.15}, {0.8, -0.45, 3.15},
    {0.45, -0.8, 3.15}, {0.0, -0.8, 3.15}, {0.0, 0.0, 2.85}, {0.2, 0.0, 2.7},
    {0.2, -0.112, 2.7}, {0.112, -0.2, 2.7}, {0.0, -0.2, 2.7}, {-0.002, 0.0, 3.15},
    {-0.45, -0.8, 3.15}, {-0.8, -0.45, 3.15}, {-0.8, 0.0, 3.15}, {-0.112, -0.2, 2.7},
    {-0.2, -0.112, 2.7}, {-0.2, 0.0, 2.7}, {0.0, 0.002, 3.15}, {-0.8, 0.45, 3.15},
    {-0.45, 0.8, 3.15}, {0.0, 0.8, 3.15}, {-0.2, 0.112, 2.7}, {-0.112, 0.2, 2.7},
    {0.0, 0.2, 2.7}, {0.45, 0.8, 3.15}, {0.8, 0.45, 3.15}, {0.112, 0.2, 2.7},
    {0.2, 0.112, 2.7}, {0.4, 0.0, 2.55}, {0.4, -0.224, 2.55}, {0.224, -0.4, 2.55},
    {0.0, -0.4, 2.55}, {1.3, 0.0, 2.55}, {1.3, -0.728, 2.55}, {0.728, -1.3, 2.55},
    {0.0, -1.3, 2.55}, {1.3, 0.0, 2.4}, {1.3, -0.728, 2.4}, {0.728, -1.3, 2.4},
    {0.0, -1.3, 2.4}, {-0.224, -0.4, 2.55}, {-0.4, -0.224, 2.55}, {-0.4, 0.0, 2.55},
    {-0.728, -1.3, 2.55}, {-1.3, -0.728, 2.55}, {-1.3, 0.0, 2.55}, {-0.728, -1.3, 2.4},
    {-1.3, -0.728, 2.4}, {-1.3, 0.0, 2.4}, {-0.4, 0.224, 2.55}, {-0.224, 0.4, 2.55},
    {0.0, 0.4, 2.55}, {-1.3, 0.728, 2.55}, {-0.728, 1.3, 2.55}, {0.0, 1.3, 2.55},
    {-1.3, 0.728, 2.4}, {-0.728, 1.3, 2.4}, {0.0, 1.3, 2.4}, {0.224, 0.4, 2.55},
    {0.4, 0.224, 2.55}, {0.728, 1.3, 2.55}, {1.3, 0.728, 2.55}, {0.728, 1.3, 2.4},
    {1.3, 0.728, 2.4}, {0.0, 0.0, 0.0}, {1.5, 0.0, 0.15}, {1.5, 0.84, 0.15},
    {0.84, 1.5, 0.15}, {0.0, 1.5, 0.15}, {1.5, 0.0, 0.075}, {1.5, 0.84, 0.075},
    {0.84, 1.5, 0.075}, {0.0, 1.5, 0.075}, {1.425, 0.0, 0.0}, {1.425, 0.798, 0.0},
    {0.798, 1.425, 0.0}, {0.0, 1.425, 0.0}, {-0.84, 1.5, 0.15}, {-1.5, 0.84, 0.15},
    {-1.5, 0.0, 0.15}, {-0.84, 1.5, 0.075}, {-1.5, 0.84, 0.075}, {-1.5, 0.0, 0.075},
    {-0.798, 1.425, 0.0}, {-1.425, 0.798, 0.0}, {-1.425, 0.0, 0.0}, {-1.5, -0.84, 0.15},
    {-0.84, -1.5, 0.15}, {0.0, -1.5, 0.15}, {-1.5, -0.84, 0.075}, {-0.84, -1.5, 0.075},
    {0.0, -1.5, 0.075}, {-1.425, -0.798, 0.0}, {-0.798, -1.425, 0.0}, {0.0, -1.425, 0.0},
    {0.84, -1.5, 0.15}, {1.5, -0.84, 0.15}, {0.84, -1.5, 0.075}, {1.5, -0.84, 0.075},
    {0.798, -1.425, 0.0}, {1.425, -0.798, 0.0},
}};

// The 32 patches, 16 control points each, 1-based as in the original (a remnant of its FORTRAN):
// rows of constant v, each of 4 points in u.
constexpr int kPatches1[32][16] = {
    {1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15, 16},
    {4, 17, 18, 19, 8, 20, 21, 22, 12, 23, 24, 25, 16, 26, 27, 28},
    {19, 29, 30, 31, 22, 32, 33, 34, 25, 35, 36, 37, 28, 38, 39, 40},
    {31, 41, 42, 1, 34, 43, 44, 5, 37, 45, 46, 9, 40, 47, 48, 13},
    {13, 14, 15, 16, 49, 50, 51, 52, 53, 54, 55, 56, 57, 58, 59, 60},
    {16, 26, 27, 28, 52, 61, 62, 63, 56, 64, 65, 66, 60, 67, 68, 69},
    {28, 38, 39, 40, 63, 70, 71, 72, 66, 73, 74, 75, 69, 76, 77, 78},
    {40, 47, 48, 13, 72, 79, 80, 49, 75, 81, 82, 53, 78, 83, 84, 57},
    {57, 58, 59, 60, 85, 86, 87, 88, 89, 90, 91, 92, 93, 94, 95, 96},
    {60, 67, 68, 69, 88, 97, 98, 99, 92, 100, 101, 102, 96, 103, 104, 105},
    {69, 76, 77, 78, 99, 106, 107, 108, 102, 109, 110, 111, 105, 112, 113, 114},
    {78, 83, 84, 57, 108, 115, 116, 85, 111, 117, 118, 89, 114, 119, 120, 93},
    {121, 122, 123, 124, 125, 126, 127, 128, 129, 130, 131, 132, 133, 134, 135, 136},
    {124, 137, 138, 121, 128, 139, 140, 125, 132, 141, 142, 129, 136, 143, 144, 133},
    {133, 134, 135, 136, 145, 146, 147, 148, 149, 150, 151, 152, 69, 153, 154, 155},
    {136, 143, 144, 133, 148, 156, 157, 145, 152, 158, 159, 149, 155, 160, 161, 69},
    {162, 163, 164, 165, 166, 167, 168, 169, 170, 171, 172, 173, 174, 175, 176, 177},
    {165, 178, 179, 162, 169, 180, 181, 166, 173, 182, 183, 170, 177, 184, 185, 174},
    {174, 175, 176, 177, 186, 187, 188, 189, 190, 191, 192, 193, 194, 195, 196, 197},
    {177, 184, 185, 174, 189, 198, 199, 186, 193, 200, 201, 190, 197, 202, 203, 194},
    {204, 204, 204, 204, 207, 208, 209, 210, 211, 211, 211, 211, 212, 213, 214, 215},
    {204, 204, 204, 204, 210, 217, 218, 219, 211, 211, 211, 211, 215, 220, 221, 222},
    {204, 204, 204, 204, 219, 224, 225, 226, 211, 211, 211, 211, 222, 227, 228, 229},
    {204, 204, 204, 204, 226, 230, 231, 207, 211, 211, 211, 211, 229, 232, 233, 212},
    {212, 213, 214, 215, 234, 235, 236, 237, 238, 239, 240, 241, 242, 243, 244, 245},
    {215, 220, 221, 222, 237, 246, 247, 248, 241, 249, 250, 251, 245, 252, 253, 254},
    {222, 227, 228, 229, 248, 255, 256, 257, 251, 258, 259, 260, 254, 261, 262, 263},
    {229, 232, 233, 212, 257, 264, 265, 234, 260, 266, 267, 238, 263, 268, 269, 242},
    {270, 270, 270, 270, 279, 280, 281, 282, 275, 276, 277, 278, 271, 272, 273, 274},
    {270, 270, 270, 270, 282, 289, 290, 291, 278, 286, 287, 288, 274, 283, 284, 285},
    {270, 270, 270, 270, 291, 298, 299, 300, 288, 295, 296, 297, 285, 292, 293, 294},
    {270, 270, 270, 270, 300, 305, 306, 279, 297, 303, 304, 275, 294, 301, 302, 271},
};

// Cubic Bernstein basis and its derivative at t.
void bernstein(double t, double b[4], double d[4]) {
    const double s = 1.0 - t;
    b[0] = s * s * s;
    b[1] = 3.0 * s * s * t;
    b[2] = 3.0 * s * t * t;
    b[3] = t * t * t;
    d[0] = -3.0 * s * s;
    d[1] = 3.0 * s * s - 6.0 * s * t;
    d[2] = 6.0 * s * t - 3.0 * t * t;
    d[3] = 3.0 * t * t;
}

struct PatchPoint {
    glm::dvec3 p, du, dv;
};

PatchPoint evaluate(const std::array<int, 16>& patch, double u, double v) {
    double bu[4], du[4], bv[4], dv[4];
    bernstein(u, bu, du);
    bernstein(v, bv, dv);
    PatchPoint r{glm::dvec3(0), glm::dvec3(0), glm::dvec3(0)};
    for (int i = 0; i < 4; ++i)      // rows: v
        for (int j = 0; j < 4; ++j) {  // columns: u
            const glm::dvec3& c = kPoints[std::size_t(patch[std::size_t(4 * i + j)])];
            r.p += bu[j] * bv[i] * c;
            r.du += du[j] * bv[i] * c;
            r.dv += bu[j] * dv[i] * c;
        }
    return r;
}

// The unit normal at (u, v). Where the derivatives' cross product vanishes (a patch edge collapsed
// to a point: the knob's top, the bottom's centre), the normal is the limit taken from inside the
// patch: the same cross product a small step towards the patch's centre, which converges to the
// surface normal there (both points are on the axis, where the surface is flat).
glm::dvec3 normal_at(const std::array<int, 16>& patch, double u, double v) {
    double step = 1e-4;
    for (int attempt = 0; attempt < 8; ++attempt) {
        const PatchPoint q = evaluate(patch, u, v);
        const glm::dvec3 n = glm::cross(q.du, q.dv);
        const double len = glm::length(n);
        // The patches are a few units across: |du x dv| is of order 1 away from a collapsed edge.
        if (len > 1e-9) return n / len;
        u += (0.5 - u) * step;
        v += (0.5 - v) * step;
        step *= 4;
    }
    throw RuntimeError("teapot: no normal at a patch point (the control points are wrong)");
}

// Newell's frame (Z up) to Glint's (+Y up, -Z forward): a rotation of -90 degrees about X.
glm::vec3 to_glint(const glm::dvec3& p) { return glm::vec3(float(p.x), float(p.z), float(-p.y)); }

// A patch whose first row of control points is one point: its v = 0 edge is collapsed.
bool first_row_collapsed(const std::array<int, 16>& patch) {
    return patch[0] == patch[1] && patch[1] == patch[2] && patch[2] == patch[3];
}

}  // namespace

const std::array<glm::dvec3, 306>& teapot_control_points() { return kPoints; }

const std::array<std::array<int, 16>, 32>& teapot_patches() {
    static const std::array<std::array<int, 16>, 32> patches = [] {
        std::array<std::array<int, 16>, 32> p{};
        for (std::size_t i = 0; i < 32; ++i)
            for (std::size_t k = 0; k < 16; ++k) p[i][k] = kPatches1[i][k] - 1;
        return p;
    }();
    return patches;
}

std::size_t teapot_triangle_count(int level) {
    if (level < 1) return 0;
    const std::size_t l = std::size_t(level);
    return 64 * l * l - 8 * l;  // 8 patches with a collapsed edge lose one triangle per quad along it
}

Mesh make_teapot(int level) {
    if (level < 1 || level > 1000) throw InputError("teapot: tessellation level " + std::to_string(level) + " is outside [1, 1000]");
    Mesh m;
    m.source = "teapot";
    const int n = level + 1;  // vertices along a patch edge
    for (const auto& patch : teapot_patches()) {
        const auto base = std::uint32_t(m.positions.size());
        for (int i = 0; i < n; ++i) {
            const double v = double(i) / level;
            for (int j = 0; j < n; ++j) {
                const double u = double(j) / level;
                const glm::dvec3 p = evaluate(patch, u, v).p;
                // du x dv points out of the pot for every one of Newell's patches (tested).
                const glm::dvec3 nrm = normal_at(patch, u, v);
                m.positions.push_back(to_glint(p));
                m.normals.push_back(glm::normalize(to_glint(nrm)));
            }
        }
        const bool collapsed = first_row_collapsed(patch);
        const auto at = [base, n](int i, int j) { return base + std::uint32_t(i * n + j); };
        for (int i = 0; i < level; ++i)
            for (int j = 0; j < level; ++j) {
                // Counter-clockwise seen from outside, like du x dv: (i,j) (i,j+1) (i+1,j+1) ...
                // Row i = 0 of a collapsed patch: (i,j) and (i,j+1) are the same point, so only the
                // second triangle is kept.
                if (!(collapsed && i == 0)) m.indices.insert(m.indices.end(), {at(i, j), at(i, j + 1), at(i + 1, j + 1)});
                m.indices.insert(m.indices.end(), {at(i, j), at(i + 1, j + 1), at(i + 1, j)});
            }
    }
    return m;
}

std::vector<float> resample_teapot_field(const std::vector<float>& values, int from_level, int to_level) {
    if (from_level < 1 || to_level < 1) throw InputError("teapot: tessellation levels must be at least 1");
    const std::size_t nf = std::size_t(from_level + 1), nt = std::size_t(to_level + 1);
    if (values.size() != 32 * nf * nf)
        throw InputError("teapot: " + std::to_string(values.size()) + " values for a level-" + std::to_string(from_level) +
                         " teapot of " + std::to_string(32 * nf * nf) + " vertices");
    std::vector<float> out;
    out.reserve(32 * nt * nt);
    for (std::size_t p = 0; p < 32; ++p) {
        const float* grid = values.data() + p * nf * nf;
        for (std::size_t i = 0; i < nt; ++i) {
            // Same parameter, two grids: v = i / to_level = y / from_level.
            const double y = double(i) * from_level / to_level;
            const std::size_t y0 = std::min(std::size_t(y), nf - 2);
            const double fy = y - double(y0);
            for (std::size_t j = 0; j < nt; ++j) {
                const double x = double(j) * from_level / to_level;
                const std::size_t x0 = std::min(std::size_t(x), nf - 2);
                const double fx = x - double(x0);
                const auto at = [&](std::size_t r, std::size_t c) { return double(grid[r * nf + c]); };
                const double top = at(y0, x0) * (1 - fx) + at(y0, x0 + 1) * fx;
                const double bottom = at(y0 + 1, x0) * (1 - fx) + at(y0 + 1, x0 + 1) * fx;
                out.push_back(float(top * (1 - fy) + bottom * fy));
            }
        }
    }
    return out;
}

}  // namespace glint::render
