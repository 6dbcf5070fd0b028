#include "tests/bench/light_sources.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <random>
#include <stdexcept>

#include <glm/geometric.hpp>

#include "appliance/convolution/mipmap.hpp"
#include "appliance/core/equirect.hpp"
#include "appliance/core/exr_io.hpp"

namespace glint::bench {

namespace {

constexpr double kDeg = kPi / 180.0;

glm::dvec3 look_dir(double az_deg, double el_deg) {
    // The simulator's camera_look convention: yaw about +Y from -Z, pitch up.
    const double a = az_deg * kDeg, e = el_deg * kDeg;
    return glm::normalize(glm::dvec3(-std::sin(a) * std::cos(e), std::sin(e), -std::cos(a) * std::cos(e)));
}

double disc_radius(double omega) { return std::acos(1 - omega / kTwoPi); }

HdrImage make_room(bool bright, int w, int h) {
    HdrImage m(w, h);
    std::mt19937 rng(bright ? 7 : 3);
    std::uniform_real_distribution<double> u(0, 1);
    const double scale = bright ? 3.0 : 0.08;
    for (int j = 0; j < h; ++j)
        for (int i = 0; i < w; ++i) {
            const glm::dvec3 d = texel_direction(i, j, w, h);
            double v = scale * (0.6 + 0.5 * d.y + 0.25 * std::sin(3 * column_phi(i, w)) * std::cos(2 * row_theta(j, h)));
            // Window-like panels: a few brighter rectangles, sharp edges.
            if (std::fmod(column_phi(i, w) + 10, 1.3) < 0.35 && std::abs(d.y - 0.1) < 0.25) v *= 3;
            m.set(i, j, {float(v), float(0.85 * v), float(0.7 * v)});
        }
    return m;
}

// Adds a disc of solid angle omega and radiance peak (white), with exact area coverage per texel
// (8x8 sub-samples), so the map's sum L dOmega is the source's energy plus the room it covers.
void add_source(HdrImage& m, const LightSource& s) {
    const int w = m.width(), h = m.height();
    const double cos_r = std::cos(s.radius);
    const double reach = s.radius + 3.0 * kPi / h;
    for (int j = 0; j < h; ++j) {
        const double theta = row_theta(j, h);
        const double theta_c = std::acos(std::clamp(s.dir.y, -1.0, 1.0));
        if (std::abs(theta - theta_c) > reach + kPi / h) continue;
        for (int i = 0; i < w; ++i) {
            const glm::dvec3 d = texel_direction(i, j, w, h);
            if (glm::dot(d, s.dir) < std::cos(std::min(kPi, reach + 2 * kTwoPi / w / std::max(0.05, std::sin(theta)))))
                continue;
            int in = 0;
            for (int b = 0; b < 8; ++b)
                for (int a = 0; a < 8; ++a) {
                    const double th = kPi * (j + (b + 0.5) / 8) / h;
                    const double ph = kTwoPi * (i + (a + 0.5) / 8) / w - kPi;
                    in += glm::dot(direction_from_angles(th, ph), s.dir) >= cos_r;
                }
            if (in == 0) continue;
            // Area within the row is not uniform in theta; 8 rows of sub-samples weighted by sin.
            double cover = 0, total = 0;
            for (int b = 0; b < 8; ++b) {
                const double th = kPi * (j + (b + 0.5) / 8) / h;
                int n = 0;
                for (int a = 0; a < 8; ++a) {
                    const double ph = kTwoPi * (i + (a + 0.5) / 8) / w - kPi;
                    n += glm::dot(direction_from_angles(th, ph), s.dir) >= cos_r;
                }
                cover += std::sin(th) * n;
                total += std::sin(th) * 8;
            }
            const double f = cover / total;
            Rgb c = m.at(i, j);
            c.r = float(c.r * (1 - f) + s.peak * f);
            c.g = float(c.g * (1 - f) + s.peak * f);
            c.b = float(c.b * (1 - f) + s.peak * f);
            m.set(i, j, c);
        }
    }
}

}  // namespace

std::vector<std::string> stress_map_names() {
    std::vector<std::string> names;
    for (const char* room : {"dim", "bright"})
        for (const char* peak : {"1e+02", "1e+03", "1e+04", "1e+05", "1e+06"}) names.push_back(std::string(room) + "_" + peak);
    return names;
}

std::vector<std::string> make_stress_maps(const std::string& dir) {
    const double omegas[] = {1e-5, 1e-4, 1e-3, 1e-2};
    const double peaks[] = {1e2, 1e3, 1e4, 1e5, 1e6};
    struct Place {
        double az, el;
        const char* where;
    } places[] = {{0, 90, "pole-N"},   {100, -72, "pole-S"},  {180, 20, "seam"},   {180, -40, "seam"},
                  {45, 10, "open"},    {-90, 35, "open"},     {135, -15, "open"},  {-30, -50, "open"}};
    const std::vector<std::string> names = stress_map_names();
    for (int room = 0; room < 2; ++room)
        for (int p = 0; p < 5; ++p) {
            HdrImage m = make_room(room == 1, 2048, 1024);
            const std::string& name = names[std::size_t(room * 5 + p)];
            std::ofstream list(dir + "/" + name + ".sources");
            for (int k = 0; k < 8; ++k) {
                LightSource s;
                s.dir = look_dir(places[k].az, places[k].el);
                s.omega = omegas[(k + p) % 4];
                s.radius = disc_radius(s.omega);
                s.peak = peaks[p];
                s.where = places[k].where;
                add_source(m, s);
                char line[256];
                std::snprintf(line, sizeof line, "%.9f %.9f %.9f %.9e %.9e %.9e %s\n", s.dir.x, s.dir.y, s.dir.z,
                              s.radius, s.omega, s.peak, s.where.c_str());
                list << line;
            }
            if (!list) throw std::runtime_error(dir + "/" + name + ".sources: cannot write");
            save_exr(dir + "/" + name + ".exr", m);
        }
    return names;
}

std::vector<LightSource> read_sources(const std::string& path) {
    std::ifstream in(path);
    if (!in) throw std::runtime_error(path + ": cannot read");
    std::vector<LightSource> out;
    LightSource s;
    while (in >> s.dir.x >> s.dir.y >> s.dir.z >> s.radius >> s.omega >> s.peak >> s.where) out.push_back(s);
    if (out.empty()) throw std::runtime_error(path + ": no sources");
    return out;
}

HdrImage truth_on_grid(const HdrImage& truth, int width, int height) {
    if (truth.width() == width && truth.height() == height) return truth;
    const convolution::Pyramid pyramid(truth, 2);
    for (int k = 1; k < pyramid.levels(); ++k)
        if (pyramid.level(k).width() == width && pyramid.level(k).height() == height) return pyramid.level(k);
    return truth;
}

double source_energy(const HdrImage& m, const LightSource& s, double margin_rad, double* peak) {
    const int w = m.width(), h = m.height();
    const double c = std::cos(std::min(kPi, s.radius + margin_rad));
    const std::vector<double> dw = row_solid_angles(w, h);
    double e = 0, p = 0;
    for (int j = 0; j < h; ++j)
        for (int i = 0; i < w; ++i) {
            if (glm::dot(texel_direction(i, j, w, h), s.dir) < c) continue;
            const double r = m.at(i, j).r;
            e += r * dw[std::size_t(j)];
            p = std::max(p, r);
        }
    if (peak) *peak = p;
    return e;
}

std::vector<LightSource> find_sources(const HdrImage& m, double factor, double max_omega, int max_count) {
    const int w = m.width(), h = m.height();
    const std::vector<double> dw = row_solid_angles(w, h);
    const auto lum = [&](int i, int j) {
        const Rgb c = m.at(i, j);
        return (double(c.r) + c.g + c.b) / 3.0;
    };
    double sum = 0, area = 0;
    for (int j = 0; j < h; ++j)
        for (int i = 0; i < w; ++i) {
            sum += lum(i, j) * dw[std::size_t(j)];
            area += dw[std::size_t(j)];
        }
    const double threshold = factor * sum / area;
    std::vector<int> label(std::size_t(w) * std::size_t(h), -1);
    struct Region {
        double energy = 0, omega = 0, peak = 0;
        glm::dvec3 centre{0};
        std::vector<std::size_t> texels;
        int id = 0;
    };
    std::vector<Region> regions;
    std::vector<std::size_t> stack;
    for (int j0 = 0; j0 < h; ++j0)
        for (int i0 = 0; i0 < w; ++i0) {
            const std::size_t t0 = std::size_t(j0) * std::size_t(w) + std::size_t(i0);
            if (label[t0] >= 0 || lum(i0, j0) <= threshold) continue;
            Region r;
            const int id = int(regions.size());
            r.id = id;
            label[t0] = id;
            stack.assign(1, t0);
            while (!stack.empty()) {
                const std::size_t t = stack.back();
                stack.pop_back();
                const int i = int(t % std::size_t(w)), j = int(t / std::size_t(w));
                const double l = lum(i, j);
                const glm::dvec3 d = texel_direction(i, j, w, h);
                r.energy += l * dw[std::size_t(j)];
                r.omega += dw[std::size_t(j)];
                r.peak = std::max(r.peak, l);
                r.centre += l * dw[std::size_t(j)] * d;
                r.texels.push_back(t);
                for (int dj = -1; dj <= 1; ++dj)
                    for (int di = -1; di <= 1; ++di) {
                        int ni = i + di, nj = j + dj;
                        // Across a pole: the texel half a turn round in the same row.
                        if (nj < 0 || nj >= h) {
                            nj = nj < 0 ? 0 : h - 1;
                            ni += w / 2;
                        }
                        ni = ((ni % w) + w) % w;  // across the seam
                        const std::size_t n = std::size_t(nj) * std::size_t(w) + std::size_t(ni);
                        if (label[n] >= 0 || lum(ni, nj) <= threshold) continue;
                        label[n] = id;
                        stack.push_back(n);
                    }
            }
            regions.push_back(std::move(r));
        }
    std::sort(regions.begin(), regions.end(), [](const Region& a, const Region& b) { return a.energy > b.energy; });
    std::vector<LightSource> out;
    for (const Region& r : regions) {
        if (int(out.size()) >= max_count) break;
        if (r.omega > max_omega || !(glm::length(r.centre) > 0)) continue;
        LightSource s;
        s.dir = glm::normalize(r.centre);
        s.omega = r.omega;
        s.peak = r.peak;
        double far = 0;
        for (std::size_t t : r.texels) {
            const glm::dvec3 d = texel_direction(int(t % std::size_t(w)), int(t / std::size_t(w)), w, h);
            far = std::max(far, std::acos(std::clamp(glm::dot(d, s.dir), -1.0, 1.0)));
        }
        // The texels' centres, plus half a texel's diagonal at the equator.
        s.radius = far + kPi / h;
        // Only sources apart from the other bright regions: a patch with another region inside
        // its widened disc (courtyard's small patches of sky beside the large ones) is part of a
        // bright area, and its measure would weigh that area's error at the cap's rim, not its own.
        const double rim = std::cos(std::min(kPi, s.radius + kSourceMarginRad));
        bool apart = true;
        for (int j = 0; j < h && apart; ++j)
            for (int i = 0; i < w && apart; ++i) {
                const int l = label[std::size_t(j) * std::size_t(w) + std::size_t(i)];
                apart = l < 0 || l == r.id || glm::dot(texel_direction(i, j, w, h), s.dir) < rim;
            }
        if (!apart) continue;
        const double el = std::asin(std::clamp(s.dir.y, -1.0, 1.0)) / kDeg;
        s.where = el > 80 ? "pole-N" : el < -80 ? "pole-S" : "open";
        out.push_back(s);
    }
    return out;
}

}  // namespace glint::bench
