#include "appliance/capture/calibration.hpp"

#include <algorithm>
#include <cmath>

#include <opencv2/imgproc.hpp>
#include <opencv2/photo.hpp>

#include "appliance/core/errors.hpp"

namespace glint::capture {

ResponseResult calibrate_response(const Session& s) {
    if (s.frames.size() < 3)
        throw InputError(s.dir.string() + ": a response calibration needs a bracket of at least 3 frames");
    std::vector<cv::Mat> images;
    std::vector<float> times;
    double shortest = 1e30, longest = 0;
    for (const FrameRecord& r : s.frames) {
        const CameraFrame f = load_frame(s, r);
        cv::Mat bgr;
        cv::cvtColor(f.rgb, bgr, cv::COLOR_RGB2BGR);
        images.push_back(bgr);
        const double t = r.exposure_s * r.analogue_gain * r.digital_gain;
        times.push_back(float(t));
        shortest = std::min(shortest, t);
        longest = std::max(longest, t);
    }
    if (longest < 8 * shortest)
        throw InputError(s.dir.string() + ": the bracket's exposures span only " + std::to_string(longest / shortest) +
                         "x; a response needs at least 8x (better 100x)");
    cv::Mat response;  // 256x1, CV_32FC3: relative exposure per code and channel (B, G, R)
    cv::createCalibrateRobertson(60, 0.001f)->process(images, response, times);
    ResponseResult out;
    out.frames = int(images.size());
    out.exposure_span = longest / shortest;
    std::array<double, 256> mean{};
    for (int z = 0; z < 256; ++z) {
        const cv::Vec3f v = response.at<cv::Vec3f>(z, 0);
        mean[std::size_t(z)] = (double(v[0]) + double(v[1]) + double(v[2])) / 3;
    }
    // Robertson's curve is defined up to a scale: code 254 (just below clipping) is exposure 1.
    const double scale = mean[254] > 0 ? 1.0 / mean[254] : 1.0;
    double previous = 0;
    for (int z = 0; z < 256; ++z) {
        // Strictly increasing, as the table must be: the ends are where the weights are smallest
        // and the estimate is noisiest.
        double v = std::max(0.0, mean[std::size_t(z)] * scale);
        if (z > 0 && v <= previous) v = previous * (1 + 1e-6) + 1e-12;
        out.response.inverse[std::size_t(z)] = v;
        previous = v;
    }
    out.response.gamma = 0;  // a table only
    out.response.shoulder = 0;
    return out;
}

VignettingResult calibrate_vignetting(const Session& s, const CameraCalibration& cal) {
    const Intrinsics& k = cal.intrinsics;
    const std::size_t n = std::size_t(k.width) * std::size_t(k.height);
    std::vector<double> sum(n, 0.0);
    std::vector<char> usable(n, 1);
    VignettingResult out;
    for (const FrameRecord& r : s.frames) {
        const CameraFrame f = load_frame(s, r);
        if (f.rgb.cols != k.width || f.rgb.rows != k.height)
            throw InputError(s.dir.string() + ": frame " + r.file + " is not the calibration's " + std::to_string(k.width) +
                             "x" + std::to_string(k.height));
        const double t = r.exposure_s * r.analogue_gain * r.digital_gain;
        for (int v = 0; v < k.height; ++v) {
            const std::uint8_t* row = f.rgb.ptr<std::uint8_t>(v);
            for (int u = 0; u < k.width; ++u) {
                const std::size_t i = std::size_t(v) * std::size_t(k.width) + std::size_t(u);
                double x = 0;
                for (int c = 0; c < 3; ++c) {
                    const std::uint8_t z = row[3 * u + c];
                    if (z < 10 || z > 245) usable[i] = 0;  // near black or clipping: not a measurement
                    x += cal.response.inverse[z];
                }
                sum[i] += x / (3 * t);
            }
        }
        ++out.frames;
    }
    if (out.frames == 0) throw InputError(s.dir.string() + ": no frames");
    // The falloff relative to the pixels around the principal point.
    double centre = 0;
    int centre_n = 0;
    for (int v = int(k.cy) - 2; v <= int(k.cy) + 2; ++v)
        for (int u = int(k.cx) - 2; u <= int(k.cx) + 2; ++u) {
            if (u < 0 || v < 0 || u >= k.width || v >= k.height) continue;
            const std::size_t i = std::size_t(v) * std::size_t(k.width) + std::size_t(u);
            if (!usable[i]) continue;
            centre += sum[i];
            ++centre_n;
        }
    if (centre_n == 0 || !(centre > 0))
        throw InputError(s.dir.string() + ": the frames' centre is clipped or black; expose the flat field mid-grey");
    centre /= centre_n;
    // Least squares of V - 1 = a1 r^2 + a2 r^4 + a3 r^6 (r: distance / half diagonal).
    const double half_diag = 0.5 * std::hypot(double(k.width), double(k.height));
    double A[3][3] = {}, b[3] = {};
    std::vector<std::pair<double, double>> points;
    for (int v = 0; v < k.height; ++v)
        for (int u = 0; u < k.width; ++u) {
            const std::size_t i = std::size_t(v) * std::size_t(k.width) + std::size_t(u);
            if (!usable[i]) continue;
            const double r2 = ((u - k.cx) * (u - k.cx) + (v - k.cy) * (v - k.cy)) / (half_diag * half_diag);
            const double y = sum[i] / centre - 1;
            const double x[3] = {r2, r2 * r2, r2 * r2 * r2};
            for (int p = 0; p < 3; ++p) {
                b[p] += x[p] * y;
                for (int q = 0; q < 3; ++q) A[p][q] += x[p] * x[q];
            }
            points.emplace_back(r2, y);
        }
    out.pixels = (long long)points.size();
    if (out.pixels < 100) throw InputError(s.dir.string() + ": fewer than 100 usable flat-field pixels");
    // Solve the 3x3 normal equations (Gaussian elimination with partial pivoting).
    double M[3][4];
    for (int p = 0; p < 3; ++p) {
        for (int q = 0; q < 3; ++q) M[p][q] = A[p][q];
        M[p][3] = b[p];
    }
    for (int c = 0; c < 3; ++c) {
        int pivot = c;
        for (int r = c + 1; r < 3; ++r)
            if (std::abs(M[r][c]) > std::abs(M[pivot][c])) pivot = r;
        for (int q = 0; q < 4; ++q) std::swap(M[c][q], M[pivot][q]);
        if (!(std::abs(M[c][c]) > 1e-300)) throw InputError(s.dir.string() + ": the flat field does not reach the corners");
        for (int r = 0; r < 3; ++r) {
            if (r == c) continue;
            const double f = M[r][c] / M[c][c];
            for (int q = c; q < 4; ++q) M[r][q] -= f * M[c][q];
        }
    }
    out.vignetting = {M[0][3] / M[0][0], M[1][3] / M[1][1], M[2][3] / M[2][2]};
    double e2 = 0;
    for (const auto& [r2, y] : points) {
        const double fit = r2 * (out.vignetting.a1 + r2 * (out.vignetting.a2 + r2 * out.vignetting.a3));
        e2 += (fit - y) * (fit - y);
    }
    out.fit_rms = std::sqrt(e2 / double(points.size()));
    return out;
}

}  // namespace glint::capture
