// Diagnostic: replay a session's frames through one HdrAccumulator with given orientations (the
// CSV of `glint capture --orientations-out`, or the session's truth/camera.csv), and break one
// source's energy (red x solid angle over its disc + 1.5 degrees, as the capture benchmark) into
// stages: each frame's own read of the cap, each band alone, all bands merged as one Robertson
// sum, and merge_bands (the map).
//
//   glint_bench_band_replay SESSION SOURCES INDEX ORIENTATIONS.csv [--texels] [--frames]
#include <cmath>
#include <cstdio>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include "appliance/capture/capture_pipeline.hpp"
#include "appliance/capture/exposure_bands.hpp"
#include "appliance/capture/hdr_accumulator.hpp"
#include "appliance/capture/session.hpp"
#include "appliance/core/equirect.hpp"
#include "appliance/core/rotation.hpp"
#include "appliance/core/exr_io.hpp"
#include "firmware_bridge/host/orientation_history.hpp"
#include "tests/bench/light_sources.hpp"

using namespace glint;
using namespace glint::capture;

namespace {

struct Pose {
    std::uint64_t index;
    glm::dquat q;
};

std::vector<Pose> read_poses(const std::string& path) {
    std::ifstream in(path);
    std::string line;
    std::getline(in, line);
    std::vector<Pose> out;
    while (std::getline(in, line)) {
        std::stringstream ss(line);
        std::string f[6];
        for (auto& x : f) std::getline(ss, x, ',');
        Pose p;
        p.index = std::stoull(f[0]);
        p.q = glm::dquat(std::stod(f[2]), std::stod(f[3]), std::stod(f[4]), std::stod(f[5]));
        out.push_back(p);
    }
    return out;
}

}  // namespace

// margins TRUTH.exr CAPTURED.exr [SOURCES]: each source's captured / true energy over its disc
// widened by 0.5 .. 6 degrees (the benchmark's measure takes 1.5): an error that fades as the cap
// grows is energy moved across the cap's edge (blur, registration), not energy made or lost.
int margins(int argc, char** argv) {
    const HdrImage truth_full = load_exr(argv[2]).image, got = load_exr(argv[3]).image;
    const HdrImage truth = bench::truth_on_grid(truth_full, got.width(), got.height());
    const std::vector<bench::LightSource> list = argc > 4 ? bench::read_sources(argv[4]) : bench::find_sources(truth_full);
    const double margins_deg[] = {0.5, 1.0, 1.5, 2.0, 3.0, 4.0, 6.0};
    int n = 0;
    for (const bench::LightSource& s : list) {
        ++n;
        std::printf("source %d (%s, %.2g sr, radius %.2f deg, dir %.4f %.4f %.4f):", n, s.where.c_str(), s.omega,
                    s.radius * 180 / kPi, s.dir.x, s.dir.y, s.dir.z);
        for (double m : margins_deg) {
            const double et = bench::source_energy(truth, s, m * kPi / 180), eg = bench::source_energy(got, s, m * kPi / 180);
            std::printf("  %.1f: %+.2f %%", m, 100 * (eg / et - 1));
        }
        std::printf("\n");
    }
    for (std::size_t a = 0; a < list.size(); ++a)
        for (std::size_t b = a + 1; b < list.size(); ++b) {
            const double d = std::acos(std::clamp(glm::dot(list[a].dir, list[b].dir), -1.0, 1.0));
            const double reach = list[a].radius + list[b].radius + 2 * bench::kSourceMarginRad;
            if (d < reach + 2 * kPi / 180)
                std::printf("sources %zu and %zu: %.2f deg apart, caps reach %.2f deg together\n", a + 1, b + 1,
                            d * 180 / kPi, reach * 180 / kPi);
        }
    return 0;
}

int main(int argc, char** argv) {
    if (argc >= 4 && std::string(argv[1]) == "margins") return margins(argc, argv);
    if (argc < 5) {
        std::fprintf(stderr, "usage: glint_bench_band_replay SESSION SOURCES INDEX ORIENTATIONS.csv [--texels] [--frames] [--nowt] [--out MAP.exr]\n");
        return 2;
    }
    bool texels = false, frames_out = false, no_w = false;
    std::string map_out;  // --out FILE: the replayed map (for `margins`, every source at once)
    int W = 1024, H = 512;
    for (int a = 5; a < argc; ++a) {
        std::string s = argv[a];
        if (s == "--texels") texels = true;
        if (s == "--frames") frames_out = true;
        if (s == "--nowt") no_w = true;
        if (s == "--out" && a + 1 < argc) map_out = argv[++a];
    }
    const Session session = open_session(argv[1]);
    const CameraCalibration& cal = session.calibration;
    const std::vector<bench::LightSource> sources = bench::read_sources(argv[2]);
    const bench::LightSource src = sources.at(std::size_t(std::stoi(argv[3])));
    const std::vector<Pose> poses = read_poses(argv[4]);
    std::map<std::uint64_t, const FrameRecord*> records;
    for (const FrameRecord& r : session.frames) records[r.index] = &r;

    // The sensor's angular velocity as the pipeline computes it.
    const std::vector<SensorOrientation> so = load_sensor_orientations(session);
    host::OrientationHistory hist(so.size() + 1, 100'000'000, 0);
    for (const SensorOrientation& s : so) hist.push({s.t_ns, s.world_from_sensor, 0});
    const auto w_of = [&](std::int64_t t_ns) -> glm::dvec3 {
        constexpr std::int64_t kHalf = 20'000'000;
        const std::int64_t t = t_ns + std::int64_t(std::llround(cal.time_offset_s * 1e9));
        const auto a = hist.at(t - kHalf).world_from_sensor, b = hist.at(t + kHalf).world_from_sensor;
        if (!a || !b) return glm::dvec3(0);
        const glm::dvec3 sw = rotation_vector(glm::conjugate(*a) * *b) / (2 * kHalf * 1e-9);
        return glm::conjugate(cal.sensor_from_camera) * sw;
    };

    // The cap's texels.
    const double c = std::cos(src.radius + bench::kSourceMarginRad);
    const std::vector<double> dw = row_solid_angles(W, H);
    std::vector<std::size_t> cap;
    for (int j = 0; j < H; ++j)
        for (int i = 0; i < W; ++i)
            if (glm::dot(texel_direction(i, j, W, H), src.dir) >= c) cap.push_back(std::size_t(j) * W + std::size_t(i));
    const HdrImage truth = bench::truth_on_grid(load_exr(truth_env_path(session)).image, W, H);
    double e_true = 0;
    for (std::size_t k : cap) e_true += truth.at(int(k % W), int(k / W)).r * dw[k / W];

    HdrAccumulator acc(W, H);
    std::vector<std::vector<BandTexel>> prev(cap.size());
    struct FrameStat {
        std::uint64_t index;
        double t;
        int band;
        int valid = 0, clipped = 0;
        double e = 0;      // sum over valid cap texels of (dnum/dden) dOmega
        double e_true_valid = 0;
        double wsum = 0;   // sum dwt/t (mean W) over valid
    };
    std::vector<FrameStat> fs;
    for (const Pose& p : poses) {
        const auto it = records.find(p.index);
        if (it == records.end()) continue;
        const FrameRecord& r = *it->second;
        CameraFrame f = load_frame(session, r);
        f.sequence = r.index;
        const glm::dvec3 w = no_w ? glm::dvec3(0) : w_of(f.t_ns);
        // Is the source in view at all? (skip the cap snapshot otherwise)
        const glm::dvec3 cd = glm::conjugate(p.q) * src.dir;
        const bool near = cd.z < 0 && project(cal.intrinsics, cd, 60.0).has_value();
        acc.add_frame(f, cal, p.q, 2, w);
        if (!near) continue;
        FrameStat st;
        st.index = r.index;
        st.t = r.exposure_s * r.analogue_gain * r.digital_gain * cal.sensitivity;
        st.band = exposure_band(st.t);
        for (std::size_t n = 0; n < cap.size(); ++n) {
            std::vector<BandTexel> now = acc.band_texels(cap[n]);
            std::vector<BandTexel>& old = prev[n];
            // Band lists grow (inserted in order): match by t_min is unreliable; by count of bands.
            // Find the band whose sums changed.
            for (std::size_t b = 0; b < now.size(); ++b) {
                BandTexel o{};
                // old band b' with the same position after an insertion: compare by index via t_min ordering.
                // Bands are inserted sorted; an insertion shifts later ones. Match by exposure_band(t_min).
                for (const BandTexel& x : old)
                    if (exposure_band(x.t_min) == exposure_band(now[b].t_min)) o = x;
                const double dclip = now[b].clipped - o.clipped, dreads = now[b].reads - o.reads;
                if (dclip > 0) st.clipped++;
                if (dreads > 0) {
                    const double dn = now[b].num[0] - o.num[0], dd = now[b].den[0] - o.den[0];
                    const std::size_t k = cap[n];
                    if (dd > 0) {
                        st.valid++;
                        st.e += dn / dd * dw[k / W];
                        st.e_true_valid += truth.at(int(k % W), int(k / W)).r * dw[k / W];
                        st.wsum += (now[b].wt - o.wt) / st.t;
                    }
                }
            }
            old = now;
        }
        fs.push_back(st);
    }

    // Stages.
    const HdrImage map = acc.radiance();
    if (!map_out.empty()) save_exr(map_out, map);
    double e_map = 0, e_all = 0;
    const int nb = acc.bands();
    std::vector<double> e_band(std::size_t(nb), 0), e_true_band(std::size_t(nb), 0);
    std::vector<int> n_band(std::size_t(nb), 0);
    std::vector<double> e_mix(std::size_t(nb), 0);  // the map's energy over the texels whose cut is at band b
    std::vector<int> n_cut(std::size_t(nb + 1), 0);
    std::vector<double> e_cut(std::size_t(nb + 1), 0), e_cut_true(std::size_t(nb + 1), 0), e_cut_all(std::size_t(nb + 1), 0);
    for (std::size_t k : cap) {
        const int i = int(k % W), j = int(k / W);
        const double om = dw[std::size_t(j)];
        const double m = map.at(i, j).r, t = truth.at(i, j).r;
        e_map += m * om;
        const std::vector<BandTexel> bt = acc.band_texels(k);
        double num = 0, den = 0;
        for (const BandTexel& x : bt) num += x.num[0], den += x.den[0];
        const double all = den > 0 ? std::max(0.0, num / den) : 0;
        e_all += all * om;
        for (int b = 0; b < nb; ++b)
            if (bt[std::size_t(b)].den[0] > 0) {
                e_band[std::size_t(b)] += bt[std::size_t(b)].num[0] / bt[std::size_t(b)].den[0] * om;
                e_true_band[std::size_t(b)] += t * om;
                n_band[std::size_t(b)]++;
            }
        // Which bands merge_bands kept: the number of leading bands whose sum equals the map.
        int kept = nb;
        for (int cut = 1; cut <= nb; ++cut) {
            double n2 = 0, d2 = 0;
            for (int b = 0; b < cut; ++b) n2 += bt[std::size_t(b)].num[0], d2 += bt[std::size_t(b)].den[0];
            const double v = d2 > 0 ? std::max(0.0, n2 / d2) : 0;
            if (std::abs(float(v) - m) <= 1e-6 * std::max(1.0, double(m))) {
                bool rest_empty = true;
                for (int b = cut; b < nb; ++b) rest_empty = rest_empty && !(bt[std::size_t(b)].den[0] > 0);
                kept = cut;
                if (!rest_empty || true) break;
            }
        }
        n_cut[std::size_t(kept)]++;
        e_cut[std::size_t(kept)] += m * om;
        e_cut_true[std::size_t(kept)] += t * om;
        e_cut_all[std::size_t(kept)] += all * om;
        if (texels) {
            const double d = std::acos(std::clamp(glm::dot(texel_direction(i, j, W, H), src.dir), -1.0, 1.0)) * 180 / kPi;
            std::printf("T %4d %4d d=%.2f true %10.4g map %10.4g all %10.4g kept %d |", i, j, d, t, m, all, kept);
            for (const BandTexel& x : bt)
                std::printf(" [%.3g r%g c%g t_min %.3g]", x.den[0] > 0 ? x.num[0] / x.den[0] : -1.0, x.reads, x.clipped, x.t_min);
            std::printf("\n");
        }
    }
    std::printf("source %.0e sr peak %.0e %s; cap %zu texels; bands %d\n", src.omega, src.peak, src.where.c_str(), cap.size(), nb);
    std::printf("E_true %.6g  E_map %.6g (%+.2f %%)  E_all_bands_one_sum %.6g (%+.2f %%)\n", e_true, e_map,
                100 * (e_map / e_true - 1), e_all, 100 * (e_all / e_true - 1));
    for (int b = 0; b < nb; ++b)
        std::printf("band %d: texels %d, alone %.6g against true %.6g (%+.2f %%)\n", b, n_band[std::size_t(b)],
                    e_band[std::size_t(b)], e_true_band[std::size_t(b)], 100 * (e_band[std::size_t(b)] / e_true_band[std::size_t(b)] - 1));
    for (int b = 1; b <= nb; ++b)
        std::printf("texels kept bands 0..%d: %d, map %.6g, all-bands %.6g, true %.6g\n", b - 1, n_cut[std::size_t(b)],
                    e_cut[std::size_t(b)], e_cut_all[std::size_t(b)], e_cut_true[std::size_t(b)]);
    // Frames that read the whole cap.
    std::map<int, std::pair<double, int>> by_band;
    double wsum = 0, ewsum = 0;
    for (const FrameStat& s : fs) {
        if (frames_out)
            std::printf("F %6llu t %.3g band %d valid %d clipped %d E %.6g (true over valid %.6g) %+.2f %%\n",
                        (unsigned long long)s.index, s.t, s.band, s.valid, s.clipped, s.e, s.e_true_valid,
                        s.e_true_valid > 0 ? 100 * (s.e / s.e_true_valid - 1) : 0.0);
        if (s.valid == int(cap.size()) && s.clipped == 0) {
            by_band[s.band].first += s.e;
            by_band[s.band].second++;
            wsum += s.t * s.t;
            ewsum += s.t * s.t * s.e;
        }
    }
    for (const auto& [b, v] : by_band)
        std::printf("complete frames of band %d: %d, mean E %.6g (%+.2f %%)\n", b, v.second, v.first / v.second,
                    100 * (v.first / v.second / e_true - 1));
    if (wsum > 0) std::printf("complete frames, t^2-weighted mean E %.6g (%+.2f %%)\n", ewsum / wsum, 100 * (ewsum / wsum / e_true - 1));
    return 0;
}
