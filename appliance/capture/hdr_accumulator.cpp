#include "appliance/capture/hdr_accumulator.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>

#include "appliance/capture/exposure_bands.hpp"
#include "appliance/core/equirect.hpp"
#include "appliance/core/errors.hpp"
#include "appliance/core/parallel.hpp"

namespace glint::capture {

HdrAccumulator::HdrAccumulator(int width, int height, AccumulationSettings settings)
    : width_(width), height_(height), settings_(settings) {
    if (width < 2 || height < 2) throw InputError("environment map size must be at least 2x2");
    const std::size_t n = std::size_t(width) * std::size_t(height);
    samples_.assign(n, 0);
    weight_sum_.assign(n, 0.0f);
    clipped_short_.assign(n, 0);
    pending_.assign(8, PendingFrame{});
    if (settings_.bracket_fill) {
        pending_mask_.assign(n, 0);
        pending_w_.assign(8 * n, 0.0f);
    }
    // The texel centres' sines and cosines (texel_direction's), once for every frame.
    for (int j = 0; j < height_; ++j) {
        const double theta = row_theta(j, height_);
        row_sin_.push_back(std::sin(theta));
        row_cos_.push_back(std::cos(theta));
    }
    for (int i = 0; i < width_; ++i) {
        const double phi = column_phi(i, width_);
        column_sin_.push_back(std::sin(phi));
        column_cos_.push_back(std::cos(phi));
    }
}

bool HdrAccumulator::cone_columns(int j, int width, int height, const glm::dvec3& axis, double cos_limit, int& i0,
                                  int& count) {
    const double rho = std::hypot(axis.x, axis.z);
    const double phi0 = std::atan2(axis.x, -axis.z);
    const double theta = row_theta(j, height);
    const double st = std::sin(theta), ct = std::cos(theta);
    // Columns whose direction is within the cone: cos(phi - phi0) >= q.
    const double a = st * rho;
    const double q = a > 1e-12 ? (cos_limit - ct * axis.y) / a : (ct * axis.y >= cos_limit ? -2.0 : 2.0);
    if (q > 1.0) return false;
    i0 = 0;
    count = width;
    if (q > -1.0) {
        const double half = std::acos(q);
        i0 = int(std::floor((phi0 - half + kPi) / kTwoPi * width - 0.5)) - 1;
        count = std::min(width, int(std::ceil(2 * half / kTwoPi * width)) + 3);
    }
    return true;
}

HdrAccumulator::Band& HdrAccumulator::band_for(double t) {
    return band_for_exposure(bands_, t, [&](int) {
        const std::size_t n = std::size_t(width_) * std::size_t(height_);
        Band b;
        b.num.assign(3 * n, 0.0f);
        b.den.assign(3 * n, 0.0f);
        b.wt.assign(n, 0.0f);
        b.clipped.assign(n, 0.0f);
        b.reads.assign(n, 0.0f);
        b.filled.assign(n, 0.0f);
        return b;
    });
}

int HdrAccumulator::auto_downscale(const Intrinsics& k, int map_width) {
    // Pixels per map texel at the image centre, rounded down: never blur more than one texel.
    const double per_texel = kTwoPi / map_width * std::min(k.fx, k.fy);
    // At most half the frame's shorter side, so that the filtered frame keeps 2x2 cells to read
    // between: an 8x4 map of 160x90 frames asked for cells of 89 pixels and failed ("frame too
    // small for a downscale of 89"), where a coarse map is only coarse.
    const int most = std::max(1, std::min(k.width, k.height) / 2);
    return std::clamp(int(std::floor(per_texel)), 1, most);
}

std::vector<float> HdrAccumulator::filtered_planes(const CameraFrame& frame, const CameraCalibration& cal, int s,
                                                   int& out_width, int& out_height) {
    const Intrinsics& k = cal.intrinsics;
    if (!frame.is(k.width, k.height))
        throw InputError("frame " + std::to_string(frame.sequence) + " is " + std::to_string(frame.rgb.cols) + "x" +
                         std::to_string(frame.rgb.rows) + " 8-bit RGB expected " + std::to_string(k.width) + "x" +
                         std::to_string(k.height) + " (the calibration's size)");
    out_width = k.width / s;
    out_height = k.height / s;
    std::array<double, 256> weight{};
    for (int z = 0; z < 256; ++z) weight[std::size_t(z)] = code_weight(z);
    // Code 0 holds every read whose signal plus read noise fell at or below zero: linearised as 0,
    // a dark pixel averages 0.4 sigma too bright, which the shortest brackets multiply into
    // radiance (sigma 0.002 at t = 1.7e-7 is ~5e3). With the calibration's read noise, code 0 is
    // the mean of a zero signal's noise below zero, -sigma sqrt(2 / pi), so a zero signal
    // averages to zero (a weak signal is left at most -0.05 sigma).
    std::array<double, 256> linear{};
    for (int z = 0; z < 256; ++z) linear[std::size_t(z)] = cal.response.inverse[std::size_t(z)];
    if (cal.noise_read > 0) linear[0] = std::min(linear[0], -cal.noise_read * std::sqrt(2.0 / kPi));
    std::vector<float> planes(std::size_t(out_width) * std::size_t(out_height) * kPlaneFloats, 0.0f);
    const double inv_area = 1.0 / (double(s) * s);
    for (int V = 0; V < out_height; ++V)
        for (int U = 0; U < out_width; ++U) {
            double p[3] = {0, 0, 0}, w[3] = {0, 0, 0};
            bool invalid = false;  // a pixel clipped in some channel
            for (int dv = 0; dv < s; ++dv) {
                const int v = V * s + dv;
                const std::uint8_t* row = frame.rgb.ptr<std::uint8_t>(v);
                for (int du = 0; du < s; ++du) {
                    const int u = U * s + du;
                    const double inv_v = 1.0 / cal.vignetting.at(k, u, v);
                    for (int c = 0; c < 3; ++c) {
                        const std::uint8_t z = row[3 * u + c];
                        const double wz = weight[z];
                        invalid = invalid || z == 255;
                        p[c] += linear[z] * inv_v;
                        w[c] += wz;
                    }
                }
            }
            float* o = planes.data() + (std::size_t(V) * std::size_t(out_width) + std::size_t(U)) * kPlaneFloats;
            for (int c = 0; c < 3; ++c) {
                o[c] = invalid ? 0.0f : float(p[c] * inv_area);
                o[3 + c] = invalid ? 0.0f : float(w[c] * inv_area);
            }
            o[6] = invalid ? 1.0f : 0.0f;
        }
    return planes;
}

double HdrAccumulator::texel_box_width(const Intrinsics& k, int map_width, int s) {
    // A texel's height (pi / H = 2 pi / W) in grid cells at the image centre.
    return kTwoPi / map_width * std::sqrt(k.fx * k.fy) / s;
}

std::vector<float> HdrAccumulator::accumulation_planes(const CameraFrame& frame, const CameraCalibration& cal, int s,
                                                      bool automatic_downscale, int map_width, int& pw, int& ph,
                                                      std::vector<std::uint8_t>* zone) {
    std::vector<float> planes = filtered_planes(frame, cal, s, pw, ph);
    if (zone) {
        if (automatic_downscale && texel_box_width(cal.intrinsics, map_width, s) > 1.0 + 1e-6) {
            // Both zones in one pass over the cells (footprint_zone_marks): the wide one for the
            // weights, the one above the noise floor for the reads.
            // The footprint reads only round cells that a pixel above the read noise could make.
            // In a bracket's short frames the room is noise about zero, and every cell with a
            // positive draw beside one at or below zero was "8x its dimmest neighbour": the zone
            // covered 91-100 % of those frames (interior.exr), each texel read over its whole
            // footprint, 3 projections a tap, for noise whose point read is as unbiased. The
            // floor is one pixel's 4 sigma spread over the cell's s x s pixels, so that a source
            // smaller than a pixel stays in the zone at any s (one that clipped in the bracket's
            // previous step is 1/64 of the range, 7.8 sigma, in its brightest pixel). The
            // vignetting, divided out of the planes, raises the noise towards the corners: there
            // the floor lets more noise in (more footprint reads, none fewer). The weights keep
            // the wide zone: a noise cell's own weight would favour its draws above zero.
            const double floor = kZoneNoiseSigmas * cal.noise_read / (double(s) * s);
            *zone = footprint_zone_marks(planes, pw, ph, std::max(0.0, floor));
            zone_weights(planes, pw, ph, *zone);  // every marked cell: the wide zone
            for (std::uint8_t& z : *zone) z = std::uint8_t(z >> 1);  // the cells above the floor
        } else {
            zone->clear();
        }
    }
    return planes;
}

void HdrAccumulator::zone_weights(std::vector<float>& planes, int pw, int ph, const std::vector<std::uint8_t>& zone) {
    // Robertson's weight comes from a cell's own code values: beside a small source it is high in
    // the frames where the source's light spills into the cell and near 0 where it does not (code
    // 0 weighs 0), so the frames that saw more light there count more, and a source seen in many
    // frames came out brighter than in any of them (+3.5 % for a 1e-5 sr source over 60 frames).
    // In the zone each cell takes the largest weight within the zone's reach instead: about one
    // weight per frame over a compact source, so the map holds the frames' mean energy.
    constexpr int kReach = 2;
    const std::vector<float> w(planes);
    for (int v = 0; v < ph; ++v)
        for (int u = 0; u < pw; ++u) {
            if (!zone[std::size_t(v) * std::size_t(pw) + std::size_t(u)]) continue;
            float* o = planes.data() + (std::size_t(v) * std::size_t(pw) + std::size_t(u)) * kPlaneFloats;
            for (int dv = -kReach; dv <= kReach; ++dv)
                for (int du = -kReach; du <= kReach; ++du) {
                    const int uu = u + du, vv = v + dv;
                    if (uu < 0 || uu >= pw || vv < 0 || vv >= ph) continue;
                    const float* c = w.data() + (std::size_t(vv) * std::size_t(pw) + std::size_t(uu)) * kPlaneFloats;
                    if (c[6] > 0) continue;
                    for (int k = 3; k < 6; ++k) o[k] = std::max(o[k], c[k]);
                }
        }
}

std::vector<std::uint8_t> HdrAccumulator::footprint_zone(const std::vector<float>& planes, int pw, int ph,
                                                         double noise_floor) {
    std::vector<std::uint8_t> zone = footprint_zone_marks(planes, pw, ph, noise_floor);
    for (std::uint8_t& z : zone) z = std::uint8_t(z >> 1);
    return zone;
}

std::vector<std::uint8_t> HdrAccumulator::footprint_zone_marks(const std::vector<float>& planes, int pw, int ph,
                                                               double noise_floor) {
    // Compact bright features, where point reads alias energy: cells 8 times brighter (brightest
    // channel) than the dimmest of their 3x3 neighbours, or clipped, and every cell within 2 of
    // one (bit 0), and the same for the bright cells above `noise_floor` (bit 1, a subset).
    // Elsewhere texels keep their point reads and the frame its
    // detail: averaging whole frames over the texels' footprints cost drift correction a third of
    // its corrected frames on studio (100 -> 63 of 154, measured with a box filter of the same
    // width).
    const auto xmax = [&](int u, int v) {
        const float* c = planes.data() + (std::size_t(v) * std::size_t(pw) + std::size_t(u)) * kPlaneFloats;
        // At least 0: a dark cell's unbiased code 0 reads below zero, and 8x a negative minimum
        // would put every dark neighbourhood in the zone.
        return c[6] > 0 ? 1e30 : std::max({0.0, double(c[0]), double(c[1]), double(c[2])});
    };
    std::vector<std::uint8_t> zone(std::size_t(pw) * std::size_t(ph), 0);
    constexpr int kReach = 2;
    for (int v = 0; v < ph; ++v)
        for (int u = 0; u < pw; ++u) {
            double lo = 1e30;
            for (int dv = -1; dv <= 1; ++dv)
                for (int du = -1; du <= 1; ++du)
                    lo = std::min(lo, xmax(std::clamp(u + du, 0, pw - 1), std::clamp(v + dv, 0, ph - 1)));
            const double x = xmax(u, v);
            if (!(x > 8 * lo + 1e-6) || !(x > 0)) continue;
            const std::uint8_t mark = x > noise_floor ? 3 : 1;
            for (int dv = -kReach; dv <= kReach; ++dv)
                for (int du = -kReach; du <= kReach; ++du) {
                    const int uu = u + du, vv = v + dv;
                    if (uu >= 0 && uu < pw && vv >= 0 && vv < ph)
                        zone[std::size_t(vv) * std::size_t(pw) + std::size_t(uu)] |= mark;
                }
        }
    return zone;
}

int HdrAccumulator::footprint_taps(double box_cells) {
    // Taps at most half a cell apart: the bilinear tent of the cells summed over taps that close
    // is flat to 0.4 % (its ripple is sinc^2 of the tent's width over the spacing).
    return std::clamp(int(std::ceil(2.0 * box_cells)), 2, 6);
}

void HdrAccumulator::sample_planes(const std::vector<float>& planes, int pw, int ph, double U, double V,
                                   double out[kPlaneFloats]) {
    U = std::clamp(U, 0.0, double(pw - 1));
    V = std::clamp(V, 0.0, double(ph - 1));
    const int u0 = std::min(int(U), pw - 2), v0 = std::min(int(V), ph - 2);
    const double fu = U - u0, fv = V - v0;
    const float* p00 = planes.data() + (std::size_t(v0) * std::size_t(pw) + std::size_t(u0)) * kPlaneFloats;
    const float* p01 = p00 + kPlaneFloats;
    const float* p10 = p00 + std::size_t(pw) * kPlaneFloats;
    const float* p11 = p10 + kPlaneFloats;
    for (int c = 0; c < 6; ++c)
        out[c] = (1 - fv) * ((1 - fu) * p00[c] + fu * p01[c]) + fv * ((1 - fu) * p10[c] + fu * p11[c]);
    // All four cells, whatever their bilinear weight: the GPU makes the same integer decision.
    out[6] = std::max(std::max(p00[6], p01[6]), std::max(p10[6], p11[6]));
}

std::optional<PixelCoord> rolling_shutter_project(const CameraCalibration& cal, const glm::dvec3& c,
                                                  const glm::dvec3& w, double margin) {
    const Intrinsics& k = cal.intrinsics;
    if (!(cal.readout_s > 0) || w == glm::dvec3(0)) return project(k, c, margin);
    // The first guess may land off the image while its row's view sees it inside: a margin of
    // the largest shift a row can have, plus a pixel.
    const double shift_px = glm::length(w) * 0.5 * cal.readout_s * std::max(k.fx, k.fy) + 1.0;
    std::optional<PixelCoord> px = project(k, c, margin + shift_px);
    for (int iteration = 0; iteration < 2 && px; ++iteration) {
        // Row v's orientation is the frame's x exp(w dt(v)): camera_from_world turns by exp(-w dt).
        const glm::dvec3 row_dir = rotate_by_vector(-cal.row_time_offset_s(px->v) * w, c);
        px = project(k, row_dir, iteration == 1 ? margin : margin + shift_px);
    }
    return px;
}

bool HdrAccumulator::in_zone(const std::vector<std::uint8_t>& zone, int pw, int ph, double U, double V) {
    const int u = std::clamp(int(std::lround(U)), 0, pw - 1), v = std::clamp(int(std::lround(V)), 0, ph - 1);
    return zone[std::size_t(v) * std::size_t(pw) + std::size_t(u)] != 0;
}

void HdrAccumulator::prepare_footprint_trig(int taps) {
    if (taps <= 0 || taps == trig_taps_) return;
    trig_taps_ = taps;
    sub_rows_.assign(std::size_t(height_), {});
    for (int j = 0; j < height_; ++j) {
        // The two rows round each pole are caps and rings of a few pixels whose sub-rows' areas
        // grow as (2b + 1): four times the sub-rows there (3 gave a source at the pole -4.6 %, 12
        // -0.2 %).
        const int sub_rows = j < 2 || j >= height_ - 2 ? 4 * taps : taps;
        for (int b = 0; b < sub_rows; ++b) {
            const double y0 = j + double(b) / sub_rows, y1 = j + double(b + 1) / sub_rows;
            // The sub-row's solid angle (per unit of azimuth) cos(t0) - cos(t1) = 2 sin(tm) sin(d),
            // and its tap at the middle by area, where the cosine is the mean of the two:
            // 1 - cos(theta) = 2 (sin^2(tm / 2) + cos(tm) sin^2(d / 2)), tm the middle angle, d half
            // the width. These forms, without an inverse cosine, hold in single precision (the
            // GPU's) near the poles; llvmpipe's acos and asin were far too coarse for it.
            const double tm = 0.5 * kPi * (y0 + y1) / height_, d = 0.5 * kPi * (y1 - y0) / height_;
            const double w_row = 2 * std::sin(tm) * std::sin(d);
            const double sh = std::sin(0.5 * tm), sd = std::sin(0.5 * d);
            const double one_minus_cos = 2 * (sh * sh + std::cos(tm) * sd * sd);
            const double cos_t = 1 - one_minus_cos, sin_t = std::sqrt(std::max(0.0, one_minus_cos * (2 - one_minus_cos)));
            sub_rows_[std::size_t(j)].push_back({w_row, cos_t, sin_t});
        }
    }
    tap_sin_.resize(std::size_t(width_) * std::size_t(taps));
    tap_cos_.resize(tap_sin_.size());
    for (int i = 0; i < width_; ++i)
        for (int a = 0; a < taps; ++a) {
            const double phi = kTwoPi * (i + (a + 0.5) / taps) / width_ - kPi;
            tap_sin_[std::size_t(i) * std::size_t(taps) + std::size_t(a)] = std::sin(phi);
            tap_cos_[std::size_t(i) * std::size_t(taps) + std::size_t(a)] = std::cos(phi);
        }
}

void HdrAccumulator::footprint_read(const std::vector<float>& planes, int pw, int ph, int s,
                                    const CameraCalibration& cal, const glm::dquat& camera_from_world,
                                    const glm::dvec3& angular_velocity, int i, int j, int taps,
                                    double P[kPlaneFloats]) const {
    // The texel's own area on the sphere, taps x taps points of it, each sub-row weighed by its
    // solid angle (at a pole the rows of a texel differ by far more than at the equator), each
    // point read bilinearly: the texel gets the frame's mean over its footprint, whatever the
    // footprint's shape, size or tilt in the image.
    // A tap whose read touches an invalid (clipped) cell makes the texel invalid: the clipped
    // cell's unknown light reaches the texel through the reconstruction, so the read is only a
    // lower bound, and a long exposure's low value would then outweigh the short ones by t^2 (a
    // sub-pixel source at 100 kept 83 % when such taps were only left out).
    double acc[6] = {0, 0, 0, 0, 0, 0}, wsum = 0;
    bool invalid = false;
    // The sub-rows' weights and polar angles (four times the sub-rows in the two rows round each
    // pole) and the taps' azimuths: prepare_footprint_trig, for these taps.
    const std::vector<SubRow>& rows = sub_rows_[std::size_t(j)];
    const double* tap_sin = tap_sin_.data() + std::size_t(i) * std::size_t(taps);
    const double* tap_cos = tap_cos_.data() + std::size_t(i) * std::size_t(taps);
    for (const SubRow& row : rows) {
        const double w_row = row.w_row, cos_t = row.cos_t, sin_t = row.sin_t;
        for (int a = 0; a < taps; ++a) {
            const glm::dvec3 dir(sin_t * tap_sin[a], cos_t, -sin_t * tap_cos[a]);
            const auto px = rolling_shutter_project(cal, camera_from_world * dir, angular_velocity);
            if (!px) continue;
            double Q[kPlaneFloats];
            sample_planes(planes, pw, ph, grid_coordinate(px->u, s), grid_coordinate(px->v, s), Q);
            invalid = invalid || Q[6] > 0;
            for (int c = 0; c < 6; ++c) acc[c] += w_row * Q[c];
            wsum += w_row;
        }
    }
    if (!(wsum > 0)) return;  // no tap in the image: keep the centre's read
    for (int c = 0; c < 6; ++c) P[c] = acc[c] / wsum;
    P[6] = invalid || P[6] > 0 ? 1.0 : 0.0;
}

FrameContribution HdrAccumulator::add_frame(const CameraFrame& frame, const CameraCalibration& cal,
                                            const glm::dquat& world_from_camera, int threads,
                                            const glm::dvec3& angular_velocity) {
    const Intrinsics& k = cal.intrinsics;
    const double t = frame.exposure_s * frame.total_gain() * cal.sensitivity;
    if (!(t > 0) || !std::isfinite(t))
        throw InputError("frame " + std::to_string(frame.sequence) + ": exposure x gain must be positive");
    FrameContribution out;
    out.downscale = settings_.downscale > 0 ? settings_.downscale : auto_downscale(k, width_);
    const int s = out.downscale;
    int pw = 0, ph = 0;
    std::vector<std::uint8_t> zone;
    const std::vector<float> planes =
        accumulation_planes(frame, cal, s, settings_.downscale <= 0, width_, pw, ph, &zone);
    if (pw < 2 || ph < 2) throw InputError("frame too small for a downscale of " + std::to_string(s));
    const int taps = zone.empty() ? 0 : footprint_taps(texel_box_width(k, width_, s));

    const glm::dvec3 fwd = world_from_camera * glm::dvec3(0, 0, -1);
    // The rolling shutter turns the top and bottom rows' views by up to half the readout's turn
    // (an angle d lowers a cosine by at most d).
    const double rows_turn = 0.5 * cal.readout_s * glm::length(angular_velocity);
    const double cos_limit = std::max(-1.0, min_cos_to_axis(k) - 0.02 - rows_turn);
    const glm::dquat camera_from_world = glm::conjugate(world_from_camera);
    Band& band = band_for(t);
    // A frame at the sensor's shortest exposure (and gain 1 or less): what clips here clips in
    // every frame the camera can take.
    const bool shortest = frame.exposure_s * frame.total_gain() <= cal.min_exposure_s * 1.001;
    if (shortest) {
        clip_radiance_ = 1.0 / t;
        glare_fraction_ = cal.glare_fraction;
        glare_sigma_rad_ = cal.glare_sigma_rad;
        pixel_rad_ = s / std::sqrt(k.fx * k.fy);
        const double b = settings_.downscale <= 0 ? texel_box_width(k, width_, s) : 1.0;
        box_spreads_ = b > 1.0 + 1e-6;  // the footprint's taps reach a clipped cell beside the texel
    }
    prepare_footprint_trig(taps);
    std::vector<long long> in_view(std::size_t(height_), 0), sampled(std::size_t(height_), 0);

    // Bracket fill: frames whose clipped reads this frame can fill are the earlier frames of its
    // bracket: longer exposures shortly before it. Any other frame ends their wait.
    std::uint8_t expired = 0;
    for (std::size_t slot = 0; slot < pending_.size(); ++slot) {
        PendingFrame& p = pending_[slot];
        if (!(p.t > 0)) continue;
        if (!settings_.bracket_fill || !(t < p.t) || frame.t_ns < p.t_ns || frame.t_ns - p.t_ns > kBracketSpanNs) {
            expired = std::uint8_t(expired | (1u << slot));
            p = PendingFrame{};
        }
    }
    if (expired)
        for (std::uint8_t& m : pending_mask_) m = std::uint8_t(m & ~expired);
    // The bands of the waiting frames (looked up now: band_for above may have moved them).
    std::array<Band*, 8> pending_band{};
    std::array<double, 8> pending_t{};
    std::uint8_t waiting = 0;
    for (std::size_t slot = 0; slot < pending_.size(); ++slot) {
        if (!(pending_[slot].t > 0)) continue;
        for (Band& b : bands_)
            if (b.index == pending_[slot].band_index) pending_band[slot] = &b;
        pending_t[slot] = pending_[slot].t;
        if (pending_band[slot]) waiting = std::uint8_t(waiting | (1u << slot));
    }
    // This frame's own slot, for its clipped reads.
    int own_slot = -1;
    for (std::size_t slot = 0; slot < pending_.size() && own_slot < 0; ++slot)
        if (!(pending_[slot].t > 0)) own_slot = int(slot);
    if (own_slot < 0) {  // all taken (more than 8 frames in one bracket): the oldest gives way
        std::size_t oldest = 0;
        for (std::size_t slot = 1; slot < pending_.size(); ++slot)
            if (pending_[slot].t_ns < pending_[oldest].t_ns) oldest = slot;
        own_slot = int(oldest);
        const std::uint8_t bit = std::uint8_t(1u << oldest);
        for (std::uint8_t& m : pending_mask_) m = std::uint8_t(m & ~bit);
        waiting = std::uint8_t(waiting & ~bit);
    }
    const std::uint8_t own_bit = std::uint8_t(1u << own_slot);

    parallel_for(height_, threads, [&](int j) {
        int i0 = 0, count = 0;
        if (!cone_columns(j, width_, height_, fwd, cos_limit, i0, count)) return;
        for (int n = 0; n < count; ++n) {
            const int i = ((i0 + n) % width_ + width_) % width_;
            // texel_direction(i, j) from the cached sines and cosines (direction_from_angles).
            const double st = row_sin_[std::size_t(j)];
            const glm::dvec3 centre(st * column_sin_[std::size_t(i)], row_cos_[std::size_t(j)],
                                    -st * column_cos_[std::size_t(i)]);
            const auto px = rolling_shutter_project(cal, camera_from_world * centre, angular_velocity);
            if (!px) continue;
            ++in_view[std::size_t(j)];
            double P[kPlaneFloats];
            const double U = grid_coordinate(px->u, s), V = grid_coordinate(px->v, s);
            sample_planes(planes, pw, ph, U, V, P);
            if (taps > 0 && in_zone(zone, pw, ph, U, V))
                footprint_read(planes, pw, ph, s, cal, camera_from_world, angular_velocity, i, j, taps, P);
            const std::size_t texel = std::size_t(j) * std::size_t(width_) + std::size_t(i);
            if (P[6] > 0) {  // an invalid cell: no sample (see the header), but counted (merge_bands)
                band.clipped[texel] += 1.0f;
                // Waits for the next, shorter frame of the bracket (bracket fill), if the clipped
                // read has a weight of its own (a cell of the footprint zone near unclipped ones).
                // One without (a clip wider than the zone's reach) stays a clipped read for the
                // merge's rules: filled with the filling frame's weight, 1-3 such copies of a short
                // read made the longest bands "complete" at a lamp's edge, where their t^2 then
                // outweighed every short read (studio's irradiance 0.31 -> 0.61 %; without them
                // 0.29 %, 2026-12-05, docs/capture.md "Bracket fill").
                const double own_w = (P[3] + P[4] + P[5]) / 3;
                if (settings_.bracket_fill && own_w > 0) {
                    pending_mask_[texel] = std::uint8_t(pending_mask_[texel] | own_bit);
                    pending_w_[8 * texel + std::size_t(own_slot)] = float(own_w);
                }
                if (shortest) {
                    if (!clipped_short_[texel]) ++samples_[texel];  // estimated by radiance()
                    clipped_short_[texel] = 1;
                }
                continue;
            }
            double wmean = 0;
            for (int c = 0; c < 3; ++c) {
                band.num[3 * texel + std::size_t(c)] += float(t * P[3 + c] * P[c]);
                band.den[3 * texel + std::size_t(c)] += float(P[3 + c] * t * t);
                wmean += P[3 + c];
            }
            wmean /= 3;
            // Bracket fill: the earlier frames of this bracket that clipped here read now what
            // this frame reads, as radiance, in their own bands and with their own t: their
            // reads of the texel are then no censored sample (docs/capture.md, "Bracket fill").
            if (const std::uint8_t fill = waiting ? std::uint8_t(pending_mask_[texel] & waiting) : std::uint8_t(0)) {
                for (int slot = 0; slot < 8; ++slot) {
                    if (!(fill & (1u << slot))) continue;
                    Band& pb = *pending_band[std::size_t(slot)];
                    const double tp = pending_t[std::size_t(slot)];
                    // The clipped read's own weight (> 0: only such reads wait for a fill).
                    const double wl = pending_w_[8 * texel + std::size_t(slot)];
                    for (int c = 0; c < 3; ++c) {
                        pb.num[3 * texel + std::size_t(c)] += float(wl * tp * tp * (P[c] / t));
                        pb.den[3 * texel + std::size_t(c)] += float(wl * tp * tp);
                    }
                    pb.wt[texel] += float(wl * tp);
                    pb.reads[texel] += 1.0f;
                    pb.filled[texel] += 1.0f;
                    pb.clipped[texel] -= 1.0f;
                }
                pending_mask_[texel] = std::uint8_t(pending_mask_[texel] & ~fill);
            }
            band.wt[texel] += float(wmean * t);
            band.reads[texel] += 1.0f;
            weight_sum_[texel] += float(wmean);
            if (wmean >= settings_.min_weight) {
                ++samples_[texel];
                ++sampled[std::size_t(j)];
            }
        }
    });
    for (int j = 0; j < height_; ++j) {
        out.texels_in_view += in_view[std::size_t(j)];
        out.texels_sampled += sampled[std::size_t(j)];
    }
    if (settings_.bracket_fill) pending_[std::size_t(own_slot)] = PendingFrame{band.index, t, frame.t_ns};
    ++frames_;
    return out;
}

Rgb HdrAccumulator::merged(std::size_t k, std::vector<BandTexel>& texel) const {
    texel.resize(bands_.size());
    for (std::size_t b = 0; b < bands_.size(); ++b) {
        const Band& band = bands_[b];
        BandTexel& x = texel[b];
        for (int c = 0; c < 3; ++c) {
            x.num[c] = band.num[3 * k + std::size_t(c)];
            x.den[c] = band.den[3 * k + std::size_t(c)];
        }
        x.wt = band.wt[k];
        x.clipped = band.clipped[k];
        x.reads = band.reads[k];
        x.filled = band.filled[k];
        x.t_min = band.t_min;
    }
    return merge_bands(texel);
}

std::vector<BandTexel> HdrAccumulator::band_texels(std::size_t texel) const {
    std::vector<BandTexel> out;
    merged(texel, out);
    return out;
}

HdrImage HdrAccumulator::radiance(int threads) const {
    HdrImage image(width_, height_);
    parallel_for(height_, threads, [&](int j) {
        std::vector<BandTexel> texel;
        for (int i = 0; i < width_; ++i) image.set(i, j, merged(std::size_t(j) * std::size_t(width_) + std::size_t(i), texel));
    });
    estimate_clipped_sources(image);
    return image;
}

namespace {

// Share of a 2D Gaussian (sigma) centred at distance d from the centre of a disc of radius rho
// that falls inside the disc (flat, small angles): the glare a uniform disc of radiance 1 puts
// at distance d. Midpoint rule over the disc in polar coordinates.
double disc_glare(double d, double rho, double sigma) {
    if (rho <= 0) return 0;
    constexpr int nr = 24, na = 48;
    const double inv2s2 = 1.0 / (2 * sigma * sigma);
    double sum = 0;
    for (int a = 0; a < nr; ++a) {
        const double r = rho * (a + 0.5) / nr;
        for (int b = 0; b < na; ++b) {
            const double phi = kTwoPi * (b + 0.5) / na;
            const double dx = r * std::cos(phi) - d, dy = r * std::sin(phi);
            sum += r * std::exp(-(dx * dx + dy * dy) * inv2s2);
        }
    }
    return sum * (rho / nr) * (kTwoPi / na) * inv2s2 / kPi;
}

// Solve the small normal equations A x = b (n <= 5) by Gaussian elimination; false if singular.
bool solve(std::vector<double> a, std::vector<double> b, int n, std::vector<double>& x) {
    for (int c = 0; c < n; ++c) {
        int p = c;
        for (int r = c + 1; r < n; ++r)
            if (std::abs(a[std::size_t(r * n + c)]) > std::abs(a[std::size_t(p * n + c)])) p = r;
        if (std::abs(a[std::size_t(p * n + c)]) < 1e-300) return false;
        for (int k = 0; k < n; ++k) std::swap(a[std::size_t(c * n + k)], a[std::size_t(p * n + k)]);
        std::swap(b[std::size_t(c)], b[std::size_t(p)]);
        for (int r = c + 1; r < n; ++r) {
            const double f = a[std::size_t(r * n + c)] / a[std::size_t(c * n + c)];
            for (int k = c; k < n; ++k) a[std::size_t(r * n + k)] -= f * a[std::size_t(c * n + k)];
            b[std::size_t(r)] -= f * b[std::size_t(c)];
        }
    }
    x.assign(std::size_t(n), 0);
    for (int c = n - 1; c >= 0; --c) {
        double v = b[std::size_t(c)];
        for (int k = c + 1; k < n; ++k) v -= a[std::size_t(c * n + k)] * x[std::size_t(k)];
        x[std::size_t(c)] = v / a[std::size_t(c * n + c)];
    }
    return true;
}

}  // namespace

void HdrAccumulator::estimate_clipped_sources(HdrImage& image) const {
    estimated_.clear();
    if (!(clip_radiance_ > 0)) return;
    const int w = width_, h = height_;
    const std::size_t n = std::size_t(w) * std::size_t(h);
    const std::vector<double> dw = row_solid_angles(w, h);
    // Connected regions (8-neighbours, wrapping in azimuth) of texels clipped at the shortest exposure.
    std::vector<int> label(n, -1);
    std::vector<std::vector<std::size_t>> regions;
    for (std::size_t s = 0; s < n; ++s) {
        if (!clipped_short_[s] || label[s] >= 0) continue;
        const int id = int(regions.size());
        regions.emplace_back();
        std::vector<std::size_t> stack{s};
        label[s] = id;
        while (!stack.empty()) {
            const std::size_t q = stack.back();
            stack.pop_back();
            regions.back().push_back(q);
            const int qi = int(q % std::size_t(w)), qj = int(q / std::size_t(w));
            for (int dj = -1; dj <= 1; ++dj)
                for (int di = -1; di <= 1; ++di) {
                    const int j = qj + dj;
                    if (j < 0 || j >= h) continue;
                    const int i = ((qi + di) % w + w) % w;
                    const std::size_t r = std::size_t(j) * std::size_t(w) + std::size_t(i);
                    if (clipped_short_[r] && label[r] < 0) {
                        label[r] = id;
                        stack.push_back(r);
                    }
                }
        }
    }
    const double eta = glare_fraction_, sigma = glare_sigma_rad_;
    for (const std::vector<std::size_t>& region : regions) {
        EstimatedSource src;
        glm::dvec3 c(0);
        double omega = 0;
        for (std::size_t q : region) {
            const double o = dw[q / std::size_t(w)];
            c += o * texel_direction(int(q % std::size_t(w)), int(q / std::size_t(w)), w, h);
            omega += o;
        }
        c = glm::normalize(c);
        double reach = 0;  // angular extent of the region from its centroid
        for (std::size_t q : region)
            reach = std::max(reach, std::acos(std::clamp(glm::dot(c, texel_direction(int(q % std::size_t(w)),
                                                                                     int(q / std::size_t(w)), w, h)),
                                                         -1.0, 1.0)));
        const double r_u = std::sqrt(omega / kPi);  // the region as an equivalent disc
        src.direction = c;
        src.clipped_solid_angle = omega;
        // The annulus the halo is fitted in: beyond the region, out to 3 sigma of glare.
        const double outer = reach + 2 * kTwoPi / w + 3 * sigma;
        const double cos_outer = std::cos(outer);
        struct Sample {
            std::size_t texel;
            double d, x, y;  // angle to the centroid; tangent-plane coordinates
        };
        std::vector<Sample> ring, inner;
        // Local tangent frame at c.
        const glm::dvec3 ex = glm::normalize(glm::cross(std::abs(c.y) < 0.9 ? glm::dvec3(0, 1, 0) : glm::dvec3(1, 0, 0), c));
        const glm::dvec3 ey = glm::cross(c, ex);
        const int j_lo = std::max(0, int(std::floor((std::acos(std::clamp(c.y, -1.0, 1.0)) - outer) / kPi * h)) - 1);
        const int j_hi = std::min(h - 1, int(std::ceil((std::acos(std::clamp(c.y, -1.0, 1.0)) + outer) / kPi * h)) + 1);
        for (int j = j_lo; j <= j_hi; ++j)
            for (int i = 0; i < w; ++i) {
                const glm::dvec3 d = texel_direction(i, j, w, h);
                const double cd = glm::dot(d, c);
                if (cd < cos_outer) continue;
                const std::size_t q = std::size_t(j) * std::size_t(w) + std::size_t(i);
                const double ang = std::acos(std::clamp(cd, -1.0, 1.0));
                const Sample smp{q, ang, glm::dot(d, ex), glm::dot(d, ey)};
                if (label[q] >= 0) continue;  // this or another clipped region
                inner.push_back(smp);
                // Two texels clear of the region: right beside it the frames' partly covered
                // pixels put the source's own light, not its halo.
                if (samples_[q] > 0 && ang > reach + 2 * kTwoPi / w) ring.push_back(smp);
            }
        // Fit per channel: value = b0 + b1 x + b2 y + L * eta * disc_glare(d; rho), linear for a
        // given disc radius rho. The halo in the map is blurred once more by the frame's pixels and
        // the map's texels: sigma widened by half a texel.
        const double texel = kTwoPi / w;
        const double sig = std::sqrt(sigma * sigma + 0.25 * texel * texel);
        double rho = r_u, fitted_sigma = sig;
        double L[3] = {0, 0, 0};
        bool ok = ring.size() >= 8 && eta > 0 && sigma > 0;
        const auto glare_table = [&](double r, double sg) {
            // disc_glare(d; r, sg) at 129 distances over [0, outer], interpolated linearly.
            std::vector<double> t(129);
            for (int k = 0; k <= 128; ++k) t[std::size_t(k)] = eta * disc_glare(outer * k / 128.0, r, sg);
            return t;
        };
        const auto lookup = [&](const std::vector<double>& t, double d) {
            const double x = std::clamp(d / outer * 128.0, 0.0, 128.0);
            const int k = std::min(127, int(x));
            return t[std::size_t(k)] + (x - k) * (t[std::size_t(k + 1)] - t[std::size_t(k)]);
        };
        // The disc's radius from the region: the region is the disc dilated by the sampling (a
        // pixel that the disc touches clips, the texel box may spread it by a cell, and a texel
        // reading it bilinearly touches it: about a pixel plus half a texel, measured 0.40-0.45
        // degrees at 320 pixels over 70 degrees and 1024x512 without the box, plus a pixel with
        // it) and, where the halo itself clips, by that fringe, which depends on L: a few rounds. The halo's shape alone does not separate L from rho for a disc much wider than
        // the glare (measured: rho 25 % off, energy -17..+120 %).
        const double dilation = (box_spreads_ ? 2 : 1) * pixel_rad_ + 0.6 * texel;
        const double rho_geom = std::max(0.1 * r_u, r_u - dilation);
        rho = rho_geom;
        std::vector<double> best_table;
        // One linear fit per channel for a halo table; the weighted residual summed over channels.
        const auto fit = [&](const std::vector<double>& t, double l_out[3]) {
            double res = 0;
            for (int ch = 0; ch < 3; ++ch) {
                std::vector<double> a(16, 0.0), b(4, 0.0), x;
                double yy = 0;
                for (const Sample& smp : ring) {
                    const Rgb v = image.at(int(smp.texel % std::size_t(w)), int(smp.texel / std::size_t(w)));
                    const double y = ch == 0 ? v.r : ch == 1 ? v.g : v.b;
                    const double wgt = dw[smp.texel / std::size_t(w)];
                    const double f[4] = {1, smp.x, smp.y, lookup(t, smp.d)};
                    yy += wgt * y * y;
                    for (int r2 = 0; r2 < 4; ++r2) {
                        b[std::size_t(r2)] += wgt * f[r2] * y;
                        for (int q = 0; q < 4; ++q) a[std::size_t(r2 * 4 + q)] += wgt * f[r2] * f[q];
                    }
                }
                if (!solve(a, b, 4, x)) return -1.0;
                l_out[ch] = x[3];
                double xb = 0;
                for (int r2 = 0; r2 < 4; ++r2) xb += x[std::size_t(r2)] * b[std::size_t(r2)];
                res += std::max(0.0, yy - xb);
            }
            return res;
        };
        // sigma is the calibration's (widened for the map's sampling), not fitted: fitted, it
        // took part of a sky's glow for glare and made the large discs unstable (dim_1e+04's
        // 1e-2 sr sources -26 / +48 % against -24 / -18 % fixed).
        for (int round = 0; ok && round < 5; ++round) {
            double best = -1;
            {
                const double sg = sig;
                const std::vector<double> t = glare_table(rho, sg);
                double l_try[3];
                const double res = fit(t, l_try);
                if (res >= 0) {
                    best = res;
                    best_table = t;
                    fitted_sigma = sg;
                    for (int ch = 0; ch < 3; ++ch) L[ch] = l_try[ch];
                }
            }
            ok = best >= 0;
            if (!ok) break;
            // The fringe: how far beyond the disc's edge its halo alone still clips.
            const double l_max = std::max({L[0], L[1], L[2]});
            double fringe = 0;
            if (eta * l_max * disc_glare(rho, rho, fitted_sigma) > clip_radiance_) {
                double lo = 0, hi = 5 * sig;
                for (int it = 0; it < 30; ++it) {
                    const double mid = 0.5 * (lo + hi);
                    if (eta * l_max * disc_glare(rho + mid, rho, fitted_sigma) > clip_radiance_) lo = mid;
                    else hi = mid;
                }
                fringe = lo;
            }
            const double next = std::max(0.1 * r_u, rho_geom - fringe);
            if (std::abs(next - rho) < 1e-3 * r_u) break;
            rho = next;
        }
        ok = ok && !best_table.empty();
        src.source_radius_rad = rho;
        double e[3];
        // What is certain: the clip level over the disc the region holds (not the whole region,
        // which the sampling dilates: over the region it said 2-3 times a 1e-4 sr source's energy).
        const double bound = clip_radiance_ * kPi * rho_geom * rho_geom;
        src.lower_bound = {float(bound), float(bound), float(bound)};
        for (int ch = 0; ch < 3; ++ch) e[ch] = std::max(L[ch] * kPi * rho * rho, bound);
        src.fitted = ok && std::max({L[0], L[1], L[2]}) * kPi * rho * rho > bound;
        if (!src.fitted) {
            for (int ch = 0; ch < 3; ++ch) e[ch] = bound;
            L[0] = L[1] = L[2] = 0;
        }
        // Take the fitted halo out of the map around the region, then put the source's energy into
        // the region uniformly on top of the local background (the ring's median).
        std::vector<float> bgs[3];
        for (const Sample& smp : ring) {
            const Rgb v = image.at(int(smp.texel % std::size_t(w)), int(smp.texel / std::size_t(w)));
            const double gl = src.fitted ? lookup(best_table, smp.d) : 0.0;
            bgs[0].push_back(float(v.r - L[0] * gl));
            bgs[1].push_back(float(v.g - L[1] * gl));
            bgs[2].push_back(float(v.b - L[2] * gl));
        }
        float bg[3] = {0, 0, 0};
        for (int ch = 0; ch < 3; ++ch)
            if (!bgs[ch].empty()) {
                std::nth_element(bgs[ch].begin(), bgs[ch].begin() + std::ptrdiff_t(bgs[ch].size() / 2), bgs[ch].end());
                bg[ch] = std::max(0.0f, bgs[ch][bgs[ch].size() / 2]);
            }
        if (src.fitted)
            for (const Sample& smp : inner) {
                const int i = int(smp.texel % std::size_t(w)), j = int(smp.texel / std::size_t(w));
                const double gl = lookup(best_table, smp.d);
                Rgb v = image.at(i, j);
                v.r = float(std::max(0.0, v.r - L[0] * gl));
                v.g = float(std::max(0.0, v.g - L[1] * gl));
                v.b = float(std::max(0.0, v.b - L[2] * gl));
                image.set(i, j, v);
            }
        for (std::size_t q : region) {
            const int i = int(q % std::size_t(w)), j = int(q / std::size_t(w));
            image.set(i, j, {float(bg[0] + e[0] / omega), float(bg[1] + e[1] / omega), float(bg[2] + e[2] / omega)});
        }
        src.energy = {float(e[0]), float(e[1]), float(e[2])};
        if (std::getenv("GLINT_LOG_ESTIMATED_SOURCES"))
            std::fprintf(stderr, "estimate: dir %.3f %.3f %.3f omega %.3g reach %.3f deg r_u %.3f rho %.3f sigma %.3f deg ring %zu L %.4g E %.4g fitted %d\n",
                         c.x, c.y, c.z, omega, reach / kPi * 180, r_u / kPi * 180, rho / kPi * 180, fitted_sigma / kPi * 180, ring.size(), L[0], e[0], int(src.fitted));
        estimated_.push_back(src);
    }
}

void HdrAccumulator::update_radiance_in_view(HdrImage& image, const glm::dquat& world_from_camera, const Intrinsics& k,
                                             double margin_rad, int threads) const {
    if (image.width() != width_ || image.height() != height_) image = HdrImage(width_, height_);
    const glm::dvec3 fwd = world_from_camera * glm::dvec3(0, 0, -1);
    const double limit = std::acos(std::clamp(min_cos_to_axis(k), -1.0, 1.0)) + margin_rad + 2 * kTwoPi / width_;
    const double cos_limit = limit >= kPi ? -1.0 : std::cos(limit);
    parallel_for(height_, threads, [&](int j) {
        int i0 = 0, count = 0;
        if (!cone_columns(j, width_, height_, fwd, cos_limit, i0, count)) return;
        std::vector<BandTexel> texel;
        for (int n = 0; n < count; ++n) {
            const int i = ((i0 + n) % width_ + width_) % width_;
            image.set(i, j, merged(std::size_t(j) * std::size_t(width_) + std::size_t(i), texel));
        }
    });
}

}  // namespace glint::capture
