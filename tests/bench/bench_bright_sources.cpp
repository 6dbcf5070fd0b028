// Small, very bright sources through simulate + capture: where does their energy go?
//
//   glint_bench_bright_sources make OUTDIR
//       writes the stress maps OUTDIR/<name>.exr (2048x1024) and OUTDIR/<name>.sources: a dim and a
//       bright room, each with eight sources (1e-5 to 1e-2 sr) of one peak (1e2 to 1e6) at the north
//       pole, near the south pole (as far down as the guided scan sees), on the seam and in the open.
//   glint_bench_bright_sources frames SESSION SOURCES
//       per source, the energy each frame holds (its pixels linearised, divided by t x sensitivity,
//       times each pixel's solid angle, over the source region) against the truth's; clipped pixels
//       and the shortest exposure that sees it. Stage (a) and (b) of the loss.
//   glint_bench_bright_sources map TRUTH.exr CAPTURED.exr SOURCES
//       per source, captured energy against the truth's over the source region plus a margin, and
//       the peak; stage (c) + (d) once (a) and (b) are known.
//
// The energy of a region is sum L dOmega over the texels (or pixels) whose centre lies within
// radius + margin of the source's centre, red channel (the sources are white; the rooms are not).
// Run by tests/bench/run_bright_sources_bench.sh.
#include <cmath>
#include <cstdio>
#include <fstream>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "appliance/capture/session.hpp"
#include "appliance/convolution/convolution.hpp"
#include "appliance/core/error_metrics.hpp"
#include "appliance/core/equirect.hpp"
#include "appliance/core/exr_io.hpp"
#include "tests/bench/bench_util.hpp"
#include "tests/bench/light_sources.hpp"

using namespace glint;

namespace {

constexpr double kDeg = kPi / 180.0;
constexpr double kMargin = bench::kSourceMarginRad;  // around a source: the captured map's blur

using Source = bench::LightSource;
using bench::read_sources;

double region_energy(const HdrImage& m, const Source& s, double* peak = nullptr) {
    return bench::source_energy(m, s, kMargin, peak);
}

int make(const std::string& dir) {
    for (const std::string& name : bench::make_stress_maps(dir)) std::printf("%s\n", name.c_str());
    return 0;
}

int map(const std::string& truth_path, const std::string& captured_path, const std::string& sources) {
    const HdrImage truth = load_exr(truth_path).image, got = load_exr(captured_path).image;
    const HdrImage truth_on_grid = bench::truth_on_grid(truth, got.width(), got.height());  // the same texels as got
    std::printf("%-8s %-7s %-8s %12s %12s %8s %12s %12s\n", "omega", "peak", "where", "E_true", "E_captured",
                "error%", "peak_true", "peak_capt");
    for (const Source& s : read_sources(sources)) {
        double pt = 0, pg = 0;
        region_energy(truth, s, &pt);  // the true peak at the true resolution
        const double et = region_energy(truth_on_grid, s), eg = region_energy(got, s, &pg);
        std::printf("%-8.0e %-7.0e %-8s %12.5g %12.5g %+8.2f %12.5g %12.5g\n", s.omega, s.peak, s.where.c_str(), et, eg,
                    100 * (eg / et - 1), pt, pg);
    }
    return 0;
}

// Glare of a uniform disc of `radius` (and unit radiance) at angle `offset` from its centre, for
// a Gaussian point spread of `sigma` (all radians; midpoint quadrature over the disc).
double disc_glare(double radius, double offset, double sigma) {
    double g = 0;
    const int nr = 40, na = 80;
    for (int p = 0; p < nr; ++p)
        for (int q = 0; q < na; ++q) {
            const double r = radius * (p + 0.5) / nr, ph = kTwoPi * (q + 0.5) / na;
            const double dx = r * std::cos(ph) - offset, dy = r * std::sin(ph);
            g += r * std::exp(-(dx * dx + dy * dy) / (2 * sigma * sigma));
        }
    return g * (radius / nr) * (kTwoPi / na) / (kTwoPi * sigma * sigma);
}

double total_red(const HdrImage& m) {
    const std::vector<double> dw = row_solid_angles(m.width(), m.height());
    double e = 0;
    for (int j = 0; j < m.height(); ++j)
        for (int i = 0; i < m.width(); ++i) e += m.at(i, j).r * dw[std::size_t(j)];
    return e;
}

int downstream(const std::string& truth_path, const std::string& captured_path) {
    const HdrImage truth = load_exr(truth_path).image, got = load_exr(captured_path).image;
    const std::vector<HdrImage> want = bench::downstream_maps(truth), have = bench::downstream_maps(got);
    std::printf("mean red: true %.5g captured %.5g (%+.2f %%); irradiance %.2f %%, n = 160 %.2f %% (weighted relative RMS)\n",
                total_red(truth) / (4 * kPi), total_red(got) / (4 * kPi), 100 * (total_red(got) / total_red(truth) - 1),
                100 * compare_maps(have[0], want[0]).weighted_relative_rms,
                100 * compare_maps(have[1], want[1]).weighted_relative_rms);
    return 0;
}

// Radial profile around each source: captured and true red per 0.25 degree bin, and the glare a
// uniform disc of the source's size puts there (2 %, 1 degree Gaussian, flat approximation).
int profile(const std::string& truth_path, const std::string& captured_path, const std::string& sources) {
    const HdrImage truth = load_exr(truth_path).image, got = load_exr(captured_path).image;
    const double sigma = 1.0 * kDeg, eta = 0.02;
    for (const Source& s : read_sources(sources)) {
        std::printf("source %.0e sr peak %.0e %s (radius %.2f deg)\n  d_deg   captured      truth   truth+glare\n", s.omega,
                    s.peak, s.where.c_str(), s.radius / kDeg);
        for (int b = 0; b < 32; ++b) {
            const double d0 = b * 0.25 * kDeg, d1 = d0 + 0.25 * kDeg;
            double a = 0, t = 0;
            int n = 0;
            for (int j = 0; j < got.height(); ++j)
                for (int i = 0; i < got.width(); ++i) {
                    const double d = std::acos(std::clamp(glm::dot(texel_direction(i, j, got.width(), got.height()), s.dir), -1.0, 1.0));
                    if (d < d0 || d >= d1) continue;
                    a += got.at(i, j).r;
                    const Rgb tv = sample_bilinear(truth, texel_direction(i, j, got.width(), got.height()));
                    t += tv.r;
                    ++n;
                }
            if (!n) continue;
            // glare of the disc at the bin's centre
            const double dc = 0.5 * (d0 + d1);
            const double g = disc_glare(s.radius, dc, sigma);
            std::printf("  %5.2f %10.4g %10.4g %10.4g\n", dc / kDeg, a / n, t / n, t / n + eta * s.peak * g);
        }
    }
    return 0;
}

// Radial profile in the shortest frame that holds source number `which` whole: radiance per
// 0.25 degree bin (clipped pixels left out) against the true map's plus the modelled glare.
int frame_profile(const std::string& session_dir, const std::string& sources, int which) {
    using namespace glint::capture;
    const Session session = open_session(session_dir);
    const std::vector<TruthPose> poses = load_truth_poses(session);
    const CameraCalibration cal = session.calibration;
    const Intrinsics& k = cal.intrinsics;
    const HdrImage truth = load_exr(truth_env_path(session)).image;
    const Source s = read_sources(sources).at(std::size_t(which));
    std::size_t best = session.frames.size();
    for (std::size_t f = 0; f < session.frames.size(); ++f) {
        const glm::dvec3 c = glm::conjugate(poses[f].world_from_camera) * s.dir;
        const auto px = project(k, c, 0.0);
        if (!px || px->u < 40 || px->u > k.width - 41 || px->v < 40 || px->v > k.height - 41) continue;
        if (best == session.frames.size() || session.frames[f].exposure_s < session.frames[best].exposure_s) best = f;
    }
    if (best == session.frames.size()) return 1;
    const FrameRecord& rec = session.frames[best];
    const CameraFrame frame = load_frame(session, rec);
    const double t = rec.exposure_s * rec.analogue_gain * rec.digital_gain * cal.sensitivity;
    std::printf("frame %zu exposure %.3g s\n", best, rec.exposure_s);
    double a[40] = {}, tr[40] = {};
    int n[40] = {}, nc[40] = {};
    for (int v = 0; v < k.height; ++v)
        for (int u = 0; u < k.width; ++u) {
            const glm::dvec3 d = poses[best].world_from_camera * pixel_ray(k, u, v);
            const int b = int(std::acos(std::clamp(glm::dot(d, s.dir), -1.0, 1.0)) / (0.25 * kDeg));
            if (b >= 40) continue;
            const std::uint8_t z = frame.rgb.ptr<std::uint8_t>(v)[3 * u];
            if (z == 255) { ++nc[b]; continue; }
            a[b] += cal.response.inverse[z] / cal.vignetting.at(k, u, v) / t;
            tr[b] += sample_bilinear(truth, d).r;
            ++n[b];
        }
    const double sigma = kDeg;
    for (int b = 0; b < 40; ++b) {
        const double dc = (b + 0.5) * 0.25 * kDeg;
        const double g = disc_glare(s.radius, dc, sigma);
        std::printf("  %5.2f clipped %4d  frame %10.4g  truth %10.4g  truth+glare %10.4g\n", dc / kDeg, nc[b],
                    n[b] ? a[b] / n[b] : 0.0, n[b] ? tr[b] / n[b] : 0.0, (n[b] ? tr[b] / n[b] : 0.0) + 0.02 * s.peak * g);
    }
    return 0;
}

int frames(const std::string& session_dir, const std::string& sources) {
    using namespace glint::capture;
    const Session session = open_session(session_dir);
    const std::vector<TruthPose> poses = load_truth_poses(session);
    CameraCalibration cal = session.calibration;
    const Intrinsics& k = cal.intrinsics;
    const HdrImage truth = load_exr(truth_env_path(session)).image;
    const std::vector<Source> list = read_sources(sources);
    // Solid angle per pixel, from the rays at its edges.
    std::vector<double> pixel_omega(std::size_t(k.width) * std::size_t(k.height));
    for (int v = 0; v < k.height; ++v)
        for (int u = 0; u < k.width; ++u) {
            const glm::dvec3 a = pixel_ray(k, u + 0.5, v) - pixel_ray(k, u - 0.5, v);
            const glm::dvec3 b = pixel_ray(k, u, v + 0.5) - pixel_ray(k, u, v - 0.5);
            pixel_omega[std::size_t(v) * std::size_t(k.width) + std::size_t(u)] = glm::length(glm::cross(a, b));
        }
    struct Stat {
        int seen = 0, clipped_frames = 0;
        double sum = 0, sum2 = 0, lo = 1e30, hi = 0, t_short_seen = 1e30, t_short_unclipped = 1e30;
        int unclipped = 0;
    };
    std::vector<Stat> stat(list.size());
    std::vector<double> e_true(list.size());
    for (std::size_t n = 0; n < list.size(); ++n) e_true[n] = region_energy(truth, list[n]);
    for (std::size_t f = 0; f < session.frames.size(); ++f) {
        const FrameRecord& rec = session.frames[f];
        const glm::dquat camera_from_world = glm::conjugate(poses[f].world_from_camera);
        bool any = false;
        for (const Source& s : list) any = any || project(k, camera_from_world * s.dir, -8.0 - 0.0).has_value();
        if (!any) continue;
        const CameraFrame frame = load_frame(session, rec);
        const double t = rec.exposure_s * rec.analogue_gain * rec.digital_gain * cal.sensitivity;
        for (std::size_t n = 0; n < list.size(); ++n) {
            const Source& s = list[n];
            // The whole region inside the image, with a pixel to spare.
            const double reach = s.radius + kMargin;
            const glm::dvec3 c = camera_from_world * s.dir;
            if (!project(k, c, 0.0)) continue;
            bool inside = true;
            for (int q = 0; q < 8 && inside; ++q) {
                const glm::dvec3 axis = glm::normalize(glm::cross(c, q % 2 ? glm::dvec3(0, 1, 0) : glm::dvec3(1, 0, 0)));
                const glm::dvec3 d = glm::angleAxis(reach + 0.01, axis) * c;
                const glm::dvec3 d2 = glm::angleAxis(-(reach + 0.01), axis) * c;
                inside = project(k, d, -1.0).has_value() && project(k, d2, -1.0).has_value();
            }
            if (!inside) continue;
            const double cr = std::cos(reach);
            double e = 0;
            int clipped = 0;
            for (int v = 0; v < k.height; ++v) {
                const std::uint8_t* row = frame.rgb.ptr<std::uint8_t>(v);
                for (int u = 0; u < k.width; ++u) {
                    if (glm::dot(pixel_ray(k, u, v), c) < cr) continue;
                    const std::uint8_t z = row[3 * u];
                    clipped += z == 255;
                    e += cal.response.inverse[z] / cal.vignetting.at(k, u, v) / t *
                         pixel_omega[std::size_t(v) * std::size_t(k.width) + std::size_t(u)];
                }
            }
            Stat& st = stat[n];
            ++st.seen;
            st.t_short_seen = std::min(st.t_short_seen, rec.exposure_s);
            if (clipped) {
                ++st.clipped_frames;
                continue;
            }
            const double r = e / e_true[n];
            ++st.unclipped;
            st.sum += r;
            st.sum2 += r * r;
            st.lo = std::min(st.lo, r);
            st.hi = std::max(st.hi, r);
            st.t_short_unclipped = std::min(st.t_short_unclipped, rec.exposure_s);
        }
    }
    std::printf("%-8s %-7s %-8s %5s %7s %9s %8s %8s %8s %10s\n", "omega", "peak", "where", "seen", "clipped",
                "unclipped", "mean%", "sd%", "min..max%", "t_short");
    for (std::size_t n = 0; n < list.size(); ++n) {
        const Stat& st = stat[n];
        const double mean = st.unclipped ? st.sum / st.unclipped : 0;
        const double sd = st.unclipped > 1 ? std::sqrt(std::max(0.0, st.sum2 / st.unclipped - mean * mean)) : 0;
        std::printf("%-8.0e %-7.0e %-8s %5d %7d %9d %+8.2f %8.2f %+.1f..%+.1f %10.3g\n", list[n].omega, list[n].peak,
                    list[n].where.c_str(), st.seen, st.clipped_frames, st.unclipped, 100 * (mean - 1), 100 * sd,
                    st.unclipped ? 100 * (st.lo - 1) : 0.0, st.unclipped ? 100 * (st.hi - 1) : 0.0, st.t_short_seen);
    }
    return 0;
}

}  // namespace

int main(int argc, char** argv) {
    try {
        const std::vector<std::string> a(argv + 1, argv + argc);
        if (a.size() == 2 && a[0] == "make") return make(a[1]);
        if (a.size() == 3 && a[0] == "frames") return frames(a[1], a[2]);
        if (a.size() == 4 && a[0] == "map") return map(a[1], a[2], a[3]);
        if (a.size() == 4 && a[0] == "frameprofile") return frame_profile(a[1], a[2], std::stoi(a[3]));
        if (a.size() == 4 && a[0] == "profile") return profile(a[1], a[2], a[3]);
        if (a.size() == 3 && a[0] == "downstream") return downstream(a[1], a[2]);
        std::fprintf(stderr, "usage: glint_bench_bright_sources make OUTDIR | frames SESSION SOURCES | map TRUTH CAPTURED SOURCES\n");
        return 2;
    } catch (const std::exception& e) {
        std::fprintf(stderr, "glint_bench_bright_sources: %s\n", e.what());
        return 1;
    }
}
