#include "appliance/capture/hdr_accumulator.hpp"

#include <algorithm>
#include <cmath>

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
        return b;
    });
}

int HdrAccumulator::auto_downscale(const Intrinsics& k, int map_width) {
    // Pixels per map texel at the image centre, rounded down: never blur more than one texel.
    const double per_texel = kTwoPi / map_width * std::min(k.fx, k.fy);
    return std::max(1, int(std::floor(per_texel)));
}

std::vector<float> HdrAccumulator::filtered_planes(const CameraFrame& frame, const CameraCalibration& cal, int s,
                                                   int& out_width, int& out_height) {
    const Intrinsics& k = cal.intrinsics;
    if (frame.rgb.type() != CV_8UC3 || frame.rgb.cols != k.width || frame.rgb.rows != k.height)
        throw InputError("frame " + std::to_string(frame.sequence) + " is " + std::to_string(frame.rgb.cols) + "x" +
                         std::to_string(frame.rgb.rows) + " 8-bit RGB expected " + std::to_string(k.width) + "x" +
                         std::to_string(k.height) + " (the calibration's size)");
    out_width = k.width / s;
    out_height = k.height / s;
    std::array<double, 256> weight{};
    for (int z = 0; z < 256; ++z) weight[std::size_t(z)] = code_weight(z);
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
                        p[c] += cal.response.inverse[z] * inv_v;
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

FrameContribution HdrAccumulator::add_frame(const CameraFrame& frame, const CameraCalibration& cal,
                                            const glm::dquat& world_from_camera, int threads) {
    const Intrinsics& k = cal.intrinsics;
    const double t = frame.exposure_s * frame.total_gain() * cal.sensitivity;
    if (!(t > 0) || !std::isfinite(t))
        throw InputError("frame " + std::to_string(frame.sequence) + ": exposure x gain must be positive");
    FrameContribution out;
    out.downscale = settings_.downscale > 0 ? settings_.downscale : auto_downscale(k, width_);
    const int s = out.downscale;
    int pw = 0, ph = 0;
    const std::vector<float> planes = filtered_planes(frame, cal, s, pw, ph);
    if (pw < 2 || ph < 2) throw InputError("frame too small for a downscale of " + std::to_string(s));

    const glm::dvec3 fwd = world_from_camera * glm::dvec3(0, 0, -1);
    const double cos_limit = std::max(-1.0, min_cos_to_axis(k) - 0.02);
    const glm::dquat camera_from_world = glm::conjugate(world_from_camera);
    Band& band = band_for(t);
    std::vector<long long> in_view(std::size_t(height_), 0), sampled(std::size_t(height_), 0);

    parallel_for(height_, threads, [&](int j) {
        int i0 = 0, count = 0;
        if (!cone_columns(j, width_, height_, fwd, cos_limit, i0, count)) return;
        for (int n = 0; n < count; ++n) {
            const int i = ((i0 + n) % width_ + width_) % width_;
            const auto px = project(k, camera_from_world * texel_direction(i, j, width_, height_));
            if (!px) continue;
            ++in_view[std::size_t(j)];
            double P[kPlaneFloats];
            sample_planes(planes, pw, ph, grid_coordinate(px->u, s), grid_coordinate(px->v, s), P);
            if (P[6] > 0) continue;  // an invalid cell: no sample (see the header)
            const std::size_t texel = std::size_t(j) * std::size_t(width_) + std::size_t(i);
            double wmean = 0;
            for (int c = 0; c < 3; ++c) {
                band.num[3 * texel + std::size_t(c)] += float(t * P[3 + c] * P[c]);
                band.den[3 * texel + std::size_t(c)] += float(P[3 + c] * t * t);
                wmean += P[3 + c];
            }
            wmean /= 3;
            band.wt[texel] += float(wmean * t);
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
        x.t_min = band.t_min;
    }
    return merge_bands(texel);
}

HdrImage HdrAccumulator::radiance() const {
    HdrImage image(width_, height_);
    std::vector<BandTexel> texel;
    for (int j = 0; j < height_; ++j)
        for (int i = 0; i < width_; ++i) image.set(i, j, merged(std::size_t(j) * std::size_t(width_) + std::size_t(i), texel));
    return image;
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
