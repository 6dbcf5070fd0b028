#include "appliance/sim/camera_simulator.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>

#include <opencv2/imgproc.hpp>

#include "appliance/core/equirect.hpp"
#include "appliance/core/errors.hpp"
#include "appliance/core/parallel.hpp"
#include "appliance/core/rotation.hpp"

namespace glint::sim {

using capture::CameraFrame;
using capture::Intrinsics;

namespace {
constexpr std::size_t kSubsamples = 4;  // rays per pixel (2x2)
// Motion blur: time samples about one pixel of motion apart (with the 2x2 rays half a pixel
// apart, the streak is sampled every half pixel), at most this many per exposure.
constexpr double kPixelsPerTimeSample = 1.0;
constexpr int kMaxTimeSamples = 64;
}  // namespace

CameraSimulator::CameraSimulator(HdrImage environment, capture::CameraCalibration truth, SensorModel sensor,
                                 AutoExposureModel auto_exposure, std::uint64_t seed)
    : env_(std::move(environment)), truth_(std::move(truth)), sensor_(sensor), ae_(auto_exposure), seed_(seed) {
    const Intrinsics& k = truth_.intrinsics;
    if (k.width < 2 || k.height < 2 || !(k.fx > 0) || !(k.fy > 0))
        throw InputError("camera simulator: intrinsics need a size of at least 2x2 and positive focal lengths");
    if (truth_.response.gamma <= 0)
        throw InputError("camera simulator: the response must be parametric (it needs the forward curve)");
    rays_.resize(std::size_t(k.width) * std::size_t(k.height) * kSubsamples);
    vignette_.resize(rays_.size());
    for (int v = 0; v < k.height; ++v)
        for (int u = 0; u < k.width; ++u) {
            const std::size_t i = std::size_t(v) * std::size_t(k.width) + std::size_t(u);
            // A pixel integrates light over its area: 2x2 rays per pixel, so a light source smaller
            // than a pixel (the sun) keeps its energy instead of being point-sampled in or out.
            for (int sy = 0; sy < 2; ++sy)
                for (int sx = 0; sx < 2; ++sx)
                    rays_[i * kSubsamples + std::size_t(sy * 2 + sx)] =
                        capture::pixel_ray(k, u - 0.25 + 0.5 * sx, v - 0.25 + 0.5 * sy);
            vignette_[i] = truth_.vignetting.at(k, u, v);
        }
    // The glare's width in pixels at each pixel (glare_sigma_rad over the pixel's angular size),
    // as a mix of the narrowest and the widest.
    std::vector<double> px_sigma(std::size_t(k.width) * std::size_t(k.height));
    pixel_omega_.resize(px_sigma.size());
    for (int v = 0; v < k.height; ++v)
        for (int u = 0; u < k.width; ++u) {
            const glm::dvec3 a = capture::pixel_ray(k, u + 0.5, v) - capture::pixel_ray(k, u - 0.5, v);
            const glm::dvec3 b = capture::pixel_ray(k, u, v + 0.5) - capture::pixel_ray(k, u, v - 0.5);
            const double omega = glm::length(glm::cross(a, b));
            pixel_omega_[std::size_t(v) * std::size_t(k.width) + std::size_t(u)] = omega;
            px_sigma[std::size_t(v) * std::size_t(k.width) + std::size_t(u)] = truth_.glare_sigma_rad / std::sqrt(omega);
        }
    split_bright_texels();
    glare_px_min_ = *std::min_element(px_sigma.begin(), px_sigma.end());
    glare_px_max_ = *std::max_element(px_sigma.begin(), px_sigma.end());
    glare_mix_.resize(px_sigma.size());
    for (std::size_t i = 0; i < px_sigma.size(); ++i)
        glare_mix_[i] = glare_px_max_ > glare_px_min_ * 1.001
                            ? (px_sigma[i] - glare_px_min_) / (glare_px_max_ - glare_px_min_) : 0.0;
    exposure_s_ = std::clamp(exposure_s_, ae_.min_exposure_s, ae_.max_exposure_s);
    run_exposure_s_ = exposure_s_;
    run_gain_ = gain_;
}

CameraSimulator::CameraSimulator(HdrImage environment, capture::CameraCalibration truth, CameraRun run,
                                 host::Clock& clock, SensorModel sensor, AutoExposureModel auto_exposure,
                                 std::uint64_t seed)
    : CameraSimulator(std::move(environment), std::move(truth), sensor, auto_exposure, seed) {
    if (!(run.fps > 0) || run.frames < 0 || (run.frames > 0 && !run.world_from_camera))
        throw InputError("camera simulator: a run needs a positive frame rate and a camera path");
    run_ = std::move(run);
    clock_ = &clock;
}

void CameraSimulator::set_exposure(double exposure_s, double gain) {
    // The sensor cannot expose shorter than its shortest exposure time.
    exposure_s_ = std::max(exposure_s, truth_.min_exposure_s);
    gain_ = gain;
}

void CameraSimulator::split_bright_texels() {
    // A pixel integrates the light over its area. Reading the map at 2x2 points per pixel does so
    // for smooth light, but a source of a texel or less (the sun; 1e-5 sr is a third of a pixel)
    // is aliased: its energy in a frame swung by +-10 % with where it fell between the points, and
    // the bilinear lookup near a pole added 8 % (the lookup is not energy-preserving where the
    // rows shrink). So the brightest texels are taken out of the map above a level and their
    // excess is sent to the pixels as points instead: kSplatSide^2 points per texel, each carrying
    // its exact share of the texel's solid angle, shared by the four pixels round where it lands.
    // A frame then holds every such texel's energy exactly, wherever it falls.
    const int w = env_.width(), h = env_.height();
    const std::vector<double> row_omega = row_solid_angles(w, h);
    std::vector<float> lum(std::size_t(w) * std::size_t(h));
    double mean = 0;
    for (int j = 0; j < h; ++j)
        for (int i = 0; i < w; ++i) {
            const Rgb c = env_.at(i, j);
            const float l = std::max({c.r, c.g, c.b});
            lum[std::size_t(j) * std::size_t(w) + std::size_t(i)] = l;
            mean += row_omega[std::size_t(j)] * l;
        }
    mean /= 4 * kPi;
    // The level: kSplatAboveMean x the mean, raised if needed so that at most kMaxSplatTexels
    // texels are split (a bright sky would otherwise send a fifth of the map as points).
    double level = kSplatAboveMean * mean;
    if (lum.size() > kMaxSplatTexels) {
        std::vector<float> sorted(lum);
        std::nth_element(sorted.begin(), sorted.begin() + std::ptrdiff_t(kMaxSplatTexels), sorted.end(),
                         std::greater<float>());
        level = std::max(level, double(sorted[kMaxSplatTexels]));
    }
    if (!(level > 0)) return;
    constexpr int m = kSplatSide;
    for (int j = 0; j < h; ++j)
        for (int i = 0; i < w; ++i) {
            const float l = lum[std::size_t(j) * std::size_t(w) + std::size_t(i)];
            if (!(l > level)) continue;
            const Rgb c = env_.at(i, j);
            const double keep = level / l;
            const Rgb excess{float(c.r * (1 - keep)), float(c.g * (1 - keep)), float(c.b * (1 - keep))};
            env_.set(i, j, {float(c.r * keep), float(c.g * keep), float(c.b * keep)});
            for (int b = 0; b < m; ++b) {
                const double y0 = j + double(b) / m, y1 = j + double(b + 1) / m;
                const double omega = kTwoPi / (double(w) * m) * (std::cos(kPi * y0 / h) - std::cos(kPi * y1 / h));
                const double theta = kPi * (j + (b + 0.5) / m) / h;
                for (int a = 0; a < m; ++a) {
                    const double phi = kTwoPi * (i + (a + 0.5) / m) / w - kPi;
                    splats_.push_back({direction_from_angles(theta, phi),
                                       {float(excess.r * omega), float(excess.g * omega), float(excess.b * omega)}});
                }
            }
        }
}

double CameraSimulator::exposure_of(double radiance, double vignetting) const {
    const double electrons = radiance * vignetting * exposure_s_ * sensor_.electrons_per_radiance_second;
    return electrons * gain_ / sensor_.full_well_electrons;
}

CameraFrame CameraSimulator::render(const glm::dquat& world_from_camera, std::int64_t t_ns, int threads) {
    return render([&world_from_camera](double) { return world_from_camera; }, t_ns, threads);
}

int CameraSimulator::time_samples(const CameraPath& path, int v) const {
    if (!sensor_.motion_blur) return 1;
    // How far the view turns during the row's exposure, in pixels at the focal length: a pixel of
    // motion per time sample. Under a pixel (a still camera): one, the frame of a single view.
    const double tau = truth_.row_time_offset_s(v), half = 0.5 * exposure_s_;
    const double angle = angle_between(path(tau - half), path(tau + half));
    const double px = angle * std::max(truth_.intrinsics.fx, truth_.intrinsics.fy);
    return std::clamp(int(std::lround(px / kPixelsPerTimeSample)), 1, kMaxTimeSamples);
}

void CameraSimulator::splat_bright_texels(cv::Mat& light, const std::vector<std::vector<glm::dquat>>& row_views,
                                          const LocalView& local,
                                          const std::vector<std::vector<glm::dvec3>>& row_positions,
                                          const std::vector<std::vector<double>>& row_times) const {
    if (splats_.empty()) return;
    const Intrinsics& k = truth_.intrinsics;
    // Cull by the middle row's first view: a pixel ray is within acos(min_cos_to_axis) of the
    // axis, and the rows' views turn by at most the exposure's and the readout's motion (a margin
    // of 0.2 rad covers 400 deg/s over 20 ms plus a 30 ms exposure).
    const glm::dquat centre = row_views[std::size_t(k.height / 2)].front();
    const glm::dvec3 axis = centre * glm::dvec3(0, 0, -1);
    const double cos_limit = std::cos(std::min(kPi, std::acos(std::clamp(capture::min_cos_to_axis(k), -1.0, 1.0)) + 0.2));
    const glm::dquat camera_from_world = glm::conjugate(centre);
    for (const Splat& p : splats_) {
        if (glm::dot(p.direction, axis) < cos_limit) continue;
        // The row it lands on in the middle row's view, then the row's own view (the rolling
        // shutter moves it by well under a row between the two).
        auto px = capture::project(k, camera_from_world * p.direction, 2.0);
        if (!px) continue;
        const int row = std::clamp(int(std::lround(px->v)), 0, k.height - 1);
        const std::vector<glm::dquat>& views = row_views[std::size_t(row)];
        const double share = 1.0 / double(views.size());
        for (std::size_t m = 0; m < views.size(); ++m) {
            const glm::dquat& q = views[m];
            const auto at = capture::project(k, glm::conjugate(q) * p.direction, 1.0);
            if (!at) continue;
            // The table in front of a bright texel hides it.
            if (local.scene &&
                local.scene->radiance(row_times[std::size_t(row)][m], row_positions[std::size_t(row)][m], p.direction))
                continue;
            // Shared among the four nearest pixels by bilinear weights (which sum to 1, so the
            // frame keeps the energy): a point landing whole in one pixel left a bright area's
            // points, 0.4 pixels apart, in a moire of 4 to 9 a pixel.
            const int u0 = int(std::floor(at->u)), v0 = int(std::floor(at->v));
            const double fu = at->u - u0, fv = at->v - v0;
            for (int dv = 0; dv < 2; ++dv)
                for (int du = 0; du < 2; ++du) {
                    const int u = u0 + du, v = v0 + dv;
                    if (u < 0 || v < 0 || u >= k.width || v >= k.height) continue;
                    const std::size_t i = std::size_t(v) * std::size_t(k.width) + std::size_t(u);
                    // Energy over the pixel's solid angle: the radiance it adds to the pixel's mean.
                    const double scale = share * (du ? fu : 1 - fu) * (dv ? fv : 1 - fv) * vignette_[i] / pixel_omega_[i];
                    double* out = light.ptr<double>(v) + 3 * u;
                    out[0] += p.energy.r * scale;
                    out[1] += p.energy.g * scale;
                    out[2] += p.energy.b * scale;
                }
        }
    }
}

CameraFrame CameraSimulator::render(const CameraPath& path, std::int64_t t_ns, int threads) {
    return render(path, LocalView{}, t_ns, threads);
}

CameraFrame CameraSimulator::render(const CameraPath& path, const LocalView& local, std::int64_t t_ns, int threads) {
    if (local.scene && !local.position) throw InputError("camera simulator: a local scene needs the camera's position");
    const Intrinsics& k = truth_.intrinsics;
    CameraFrame frame;
    frame.rgb.create(k.height, k.width, CV_8UC3);
    frame.t_ns = t_ns;
    frame.exposure_s = exposure_s_;
    frame.analogue_gain = gain_;
    frame.sequence = frames_;
    const double e_scale = exposure_s_ * sensor_.electrons_per_radiance_second;  // electrons per radiance
    const double to_relative = gain_ / sensor_.full_well_electrons;
    std::vector<double> row_sums(std::size_t(k.height), 0.0);
    // The light reaching each pixel (radiance x vignetting), then the lens's glare: a share of it
    // spread as a Gaussian (camera_model.hpp; reflected at the image's edges).
    cv::Mat light(k.height, k.width, CV_64FC3);
    // Each row's orientations: its exposure (centred on the row's readout time, the rolling
    // shutter) cut into n equal slices, each seen at its middle. One slice when still.
    std::vector<std::vector<glm::dquat>> row_views(std::size_t(k.height));
    // With a local scene, the camera's position at the same times, and those times.
    std::vector<std::vector<glm::dvec3>> row_positions(local.scene ? std::size_t(k.height) : 0);
    std::vector<std::vector<double>> row_times(local.scene ? std::size_t(k.height) : 0);
    parallel_for(k.height, threads, [&](int v) {
        const int n = time_samples(path, v);
        const double tau = truth_.row_time_offset_s(v);
        std::vector<glm::dquat>& views = row_views[std::size_t(v)];
        views.resize(std::size_t(n));
        for (int m = 0; m < n; ++m) views[std::size_t(m)] = path(tau + exposure_s_ * ((m + 0.5) / n - 0.5));
        if (!local.scene) return;
        std::vector<glm::dvec3>& positions = row_positions[std::size_t(v)];
        std::vector<double>& times = row_times[std::size_t(v)];
        positions.resize(std::size_t(n));
        times.resize(std::size_t(n));
        for (int m = 0; m < n; ++m) {
            const double offset = tau + exposure_s_ * ((m + 0.5) / n - 0.5);
            positions[std::size_t(m)] = local.position(offset);
            times[std::size_t(m)] = local.t_s + offset;
        }
    });
    parallel_for(k.height, threads, [&](int v) {
        double* out = light.ptr<double>(v);
        const std::vector<glm::dquat>& views = row_views[std::size_t(v)];
        const double share = 1.0 / double(kSubsamples * views.size());
        for (int u = 0; u < k.width; ++u) {
            const std::size_t i = std::size_t(v) * std::size_t(k.width) + std::size_t(u);
            double radiance[3] = {0, 0, 0};
            for (std::size_t m = 0; m < views.size(); ++m)
                for (std::size_t sub = 0; sub < kSubsamples; ++sub) {
                    const glm::dvec3 d = views[m] * rays_[i * kSubsamples + sub];
                    std::optional<Rgb> near;
                    if (local.scene)
                        near = local.scene->radiance(row_times[std::size_t(v)][m], row_positions[std::size_t(v)][m], d);
                    const Rgb l = near ? *near : sample_bilinear(env_, d);
                    radiance[0] += l.r * share;
                    radiance[1] += l.g * share;
                    radiance[2] += l.b * share;
                }
            for (int c = 0; c < 3; ++c) out[3 * u + c] = radiance[c] * vignette_[i];
        }
    });
    splat_bright_texels(light, row_views, local, row_positions, row_times);
    if (truth_.glare_fraction > 0) {
        // The glare's width is an angle: a pixel off the axis spans less of it (cos^2 of the
        // off-axis angle for a pinhole), so its width in pixels grows there. Two blurs, at the
        // narrowest and the widest width in pixels, blended per pixel by its own width.
        cv::Mat narrow, wide;
        cv::GaussianBlur(light, narrow, cv::Size(0, 0), glare_px_min_, glare_px_min_, cv::BORDER_REFLECT);
        if (glare_px_max_ > glare_px_min_ * 1.001)
            cv::GaussianBlur(light, wide, cv::Size(0, 0), glare_px_max_, glare_px_max_, cv::BORDER_REFLECT);
        const double eta = truth_.glare_fraction;
        for (int v = 0; v < k.height; ++v) {
            double* l = light.ptr<double>(v);
            const double* a = narrow.ptr<double>(v);
            const double* b = wide.empty() ? a : wide.ptr<double>(v);
            for (int u = 0; u < k.width; ++u) {
                const double m = glare_mix_[std::size_t(v) * std::size_t(k.width) + std::size_t(u)];
                for (int c = 0; c < 3; ++c)
                    l[3 * u + c] = (1 - eta) * l[3 * u + c] + eta * ((1 - m) * a[3 * u + c] + m * b[3 * u + c]);
            }
        }
    }
    parallel_for(k.height, threads, [&](int v) {
        // One generator per (frame, row): the same frame whatever the thread count.
        std::mt19937_64 rng(seed_ * 0x9E3779B97F4A7C15ULL + frames_ * 100003ULL + std::uint64_t(v));
        std::normal_distribution<double> normal(0.0, 1.0);
        std::uint8_t* out = frame.rgb.ptr<std::uint8_t>(v);
        const double* in = light.ptr<double>(v);
        double sum = 0;
        for (int u = 0; u < k.width; ++u) {
            for (int c = 0; c < 3; ++c) {
                double electrons = in[3 * u + c] * e_scale;
                if (sensor_.noise) electrons = std::max(0.0, electrons + std::sqrt(electrons) * normal(rng));
                double x = electrons * to_relative;
                if (sensor_.noise) x += sensor_.read_noise * normal(rng);
                sum += std::clamp(x, 0.0, 1.0);
                const double z = std::round(truth_.response.forward(std::max(0.0, x)));
                out[3 * u + c] = static_cast<std::uint8_t>(std::clamp(z, 0.0, 255.0));
            }
        }
        row_sums[std::size_t(v)] = sum;
    });
    ++frames_;
    if (ae_.enabled) {
        double mean = 0;
        for (double s : row_sums) mean += s;
        mean /= 3.0 * double(k.width) * double(k.height);
        // Multiplicative correction in log space, only part of the way: the loop lags the scene.
        const double wanted = exposure_s_ * gain_ * ae_.target / std::max(mean, 1e-4);
        const double next = exposure_s_ * gain_ * std::pow(wanted / (exposure_s_ * gain_), ae_.rate);
        exposure_s_ = std::clamp(next, std::max(ae_.min_exposure_s, truth_.min_exposure_s), ae_.max_exposure_s);
        gain_ = std::clamp(next / exposure_s_, 1.0, ae_.max_gain);
    }
    return frame;
}

std::string CameraSimulator::describe() const {
    const Intrinsics& k = truth_.intrinsics;
    char text[96];
    std::snprintf(text, sizeof text, "simulator: %dx%d, %d frames at %g fps", k.width, k.height, run_.frames,
                  run_.fps);
    return text;
}

void CameraSimulator::start() {
    running_ = true;
    next_ = 0;
    frames_ = 0;
    exposure_s_ = run_exposure_s_;
    gain_ = run_gain_;
    if (clock_) start_us_ = clock_->now_us();
}

std::optional<CameraFrame> CameraSimulator::next_frame(std::chrono::milliseconds timeout) {
    if (!running_ || finished()) return std::nullopt;
    const double t_s = next_ / run_.fps;
    const std::uint64_t due_us = start_us_ + std::uint64_t(std::llround(t_s * 1e6));
    if (!capture::wait_until_due(*clock_, due_us, timeout)) {
        ++health_.timeouts;
        return std::nullopt;
    }
    ++next_;
    ++health_.frames;
    const auto& camera = run_.world_from_camera;
    return render([&camera, t_s](double offset_s) { return camera(t_s + offset_s); }, std::int64_t(due_us) * 1000,
                  run_.threads);
}

void CameraSimulator::set_exposure(const capture::ExposureRequest& request) {
    ae_.enabled = request.automatic;
    if (request.automatic) return;
    set_exposure(request.exposure_s, request.analogue_gain);
    run_exposure_s_ = exposure_s_;
    run_gain_ = gain_;
}

}  // namespace glint::sim
