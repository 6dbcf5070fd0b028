#include "appliance/capture/calibration.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <memory>
#include <optional>
#include <string>

#include <opencv2/imgproc.hpp>
#include <opencv2/calib3d.hpp>
#include <opencv2/features2d.hpp>
#include <opencv2/photo.hpp>

#include "appliance/core/errors.hpp"
#include "firmware_bridge/host/replay_source.hpp"

namespace glint::capture {

namespace {

// Refines an inverse response g (any scale) on a still bracket, where Robertson's estimate of
// g(z), the mean exposure of the reads of code z, is biased by the sensor's noise: at a code whose
// exposure is near the read noise, most reads of it come from darker pixels that noise pushed up
// (41 % at code 64 on a noisy bracket; docs/capture.md, "Calibration"). Instead each pixel
// channel's radiance E is measured from its well-exposed reads (codes kWellLow..kWellHigh, where
// noise is small beside the exposure), so that every one of its reads has a known exposure
// X = E t. The code a known exposure reads is the noise-free code plus symmetric noise, and a
// median commutes with the monotone curve and with the clamping at 0 and 255, so the median code
// over the reads of one narrow bin of X is the curve's own code there. Those medians (with
// codes spread uniformly over their rounding interval, so that the noise's dithering makes them
// finer than one code) are made non-decreasing, and g(z) is where they reach z. Repeated a few
// times, as E then comes from the refined curve.
constexpr int kWellLow = 96, kWellHigh = 250;
constexpr int kExposureBins = 1024;
constexpr long long kMinReadsPerBin = 64;
constexpr int kRefinements = 3;
constexpr double kSmoothing = 0.15;

void fill_missing_codes(std::array<double, 256>& g) {
    const auto usable = [](double v) { return std::isfinite(v) && v > 0; };
    for (int z = 0; z < 256; ++z) {
        if (usable(g[std::size_t(z)])) continue;
        int a = z - 1, b = z + 1;
        while (a >= 0 && !usable(g[std::size_t(a)])) --a;
        while (b < 256 && !usable(g[std::size_t(b)])) ++b;
        const double lo = a >= 0 ? g[std::size_t(a)] : 0.0, hi = b < 256 ? g[std::size_t(b)] : 0.0;
        g[std::size_t(z)] = a >= 0 && b < 256 ? std::sqrt(lo * hi) : a >= 0 ? lo : hi;  // 0: no code usable
    }
}

// The codes whose exposure refine_response measured (both ends included); 0..-1: none.
struct MeasuredCodes {
    int low = 0, high = -1;
};

std::array<double, 256> refine_response(const std::vector<cv::Mat>& frames, const std::vector<double>& times,
                                        std::array<double, 256> g, MeasuredCodes& range) {
    const std::size_t nf = frames.size();
    const std::size_t units = frames.front().total() * 3;  // pixel channels
    std::vector<const std::uint8_t*> code(nf);
    for (std::size_t f = 0; f < nf; ++f) code[f] = frames[f].ptr<std::uint8_t>(0);
    std::vector<double> log_t(nf);
    for (std::size_t f = 0; f < nf; ++f) log_t[f] = std::log(times[f]);
    std::vector<double> log_e(units);
    for (int pass = 0; pass < kRefinements; ++pass) {
        // Each unit's radiance: least squares of g(z) = E t over its well-exposed reads, weighted
        // as Robertson's (code_weight), so that reads near either end count least.
        double lo = INFINITY, hi = -INFINITY;
        for (std::size_t u = 0; u < units; ++u) {
            double num = 0, den = 0;
            for (std::size_t f = 0; f < nf; ++f) {
                const int z = code[f][u];
                if (z < kWellLow || z > kWellHigh) continue;
                const double w = code_weight(z);
                num += w * times[f] * g[std::size_t(z)];
                den += w * times[f] * times[f];
            }
            log_e[u] = num > 0 && den > 0 ? std::log(num / den) : NAN;
            if (std::isnan(log_e[u])) continue;
            for (std::size_t f = 0; f < nf; ++f) {
                lo = std::min(lo, log_e[u] + log_t[f]);
                hi = std::max(hi, log_e[u] + log_t[f]);
            }
        }
        if (!(hi > lo)) return g;
        // Every read of every measured unit (0 and 255 too: they place the median) into a
        // histogram of codes per bin of log X.
        const double width = (hi - lo) / kExposureBins;
        std::vector<std::uint32_t> histogram(std::size_t(kExposureBins) * 256, 0);
        for (std::size_t u = 0; u < units; ++u) {
            if (std::isnan(log_e[u])) continue;
            for (std::size_t f = 0; f < nf; ++f) {
                const int b = std::min(kExposureBins - 1, int((log_e[u] + log_t[f] - lo) / width));
                ++histogram[std::size_t(b) * 256 + code[f][u]];
            }
        }
        // Per bin its fractional median code; bins mostly clipped at either end say nothing.
        std::vector<double> xs, medians, counts;
        for (int b = 0; b < kExposureBins; ++b) {
            const std::uint32_t* h = histogram.data() + std::size_t(b) * 256;
            long long n = 0;
            for (int z = 0; z < 256; ++z) n += h[z];
            if (n < kMinReadsPerBin) continue;
            const double half = 0.5 * double(n);
            double below = 0;
            int z = 0;
            while (z < 255 && below + h[z] < half) below += h[z++];
            const double m = double(z) - 0.5 + (half - below) / std::max<double>(1, h[z]);
            if (m < 0.5 || m > 254.5) continue;
            xs.push_back(lo + (b + 0.5) * width);
            medians.push_back(m);
            counts.push_back(double(n));
        }
        if (xs.size() < 16) return g;
        // Smoothed by local linear fits in log X (tricube weights times the reads, half-width
        // kSmoothing): a bin's median scatters by the noise where the exposure is near the read
        // noise, and by whole codes without noise, which left the curve 3-6 % off code to code.
        std::vector<double> smooth(medians.size());
        const double h = kSmoothing;
        std::size_t a0 = 0;
        for (std::size_t k = 0; k < medians.size(); ++k) {
            while (xs[a0] < xs[k] - h) ++a0;
            double sw = 0, sx = 0, sy = 0, sxx = 0, sxy = 0;
            for (std::size_t j = a0; j < medians.size() && xs[j] <= xs[k] + h; ++j) {
                const double d = (xs[j] - xs[k]) / h;
                const double t = 1 - std::abs(d) * d * d;
                const double w = counts[j] * t * t * t;
                sw += w;
                sx += w * (xs[j] - xs[k]);
                sy += w * medians[j];
                sxx += w * (xs[j] - xs[k]) * (xs[j] - xs[k]);
                sxy += w * (xs[j] - xs[k]) * medians[j];
            }
            const double det = sw * sxx - sx * sx;
            smooth[k] = det > 1e-12 * sw * sw ? (sy * sxx - sx * sxy) / det : sy / sw;
        }
        // Non-decreasing in X (pool adjacent violators, weighted by the reads).
        std::vector<double> value, weight;
        std::vector<std::size_t> size;
        for (std::size_t k = 0; k < medians.size(); ++k) {
            value.push_back(smooth[k]);
            weight.push_back(counts[k]);
            size.push_back(1);
            while (value.size() > 1 && value[value.size() - 2] > value.back()) {
                const std::size_t a = value.size() - 2;
                value[a] = (value[a] * weight[a] + value.back() * weight.back()) / (weight[a] + weight.back());
                weight[a] += weight.back();
                size[a] += size.back();
                value.pop_back();
                weight.pop_back();
                size.pop_back();
            }
        }
        std::vector<double> fitted;
        for (std::size_t k = 0; k < value.size(); ++k) fitted.insert(fitted.end(), size[k], value[k]);
        // g(z): the log X where the medians reach z, between the bins either side (outside the
        // measured codes: below).
        std::array<double, 256> next{};
        std::array<bool, 256> measured{};
        std::size_t k = 0;
        for (int z = 1; z < 256; ++z) {
            while (k + 1 < fitted.size() && fitted[k + 1] < z) ++k;
            if (k + 1 >= fitted.size() || fitted[k] >= z || fitted[k + 1] < z) continue;
            const double span = fitted[k + 1] - fitted[k];
            const double a = span > 0 ? (z - fitted[k]) / span : 0.5;
            next[std::size_t(z)] = std::exp(xs[k] + a * (xs[k + 1] - xs[k]));
            measured[std::size_t(z)] = true;
        }
        int first = 256, last = -1;
        for (int z = 1; z < 256; ++z)
            if (measured[std::size_t(z)]) {
                first = std::min(first, z);
                last = z;
            }
        // The medians are non-decreasing and interpolated between neighbouring bins, so every
        // code from first to last is reached: the measured codes are one run.
        if (last - first < 32) return g;
        const auto slope = [&](int a, int b) {  // d log g / d log z between codes a < b
            return std::clamp(std::log(next[std::size_t(b)] / next[std::size_t(a)]) / std::log(double(b) / a), 0.5, 8.0);
        };
        // Below the measured codes the curve carries on as a power of the code (its log-log slope
        // over the 16 lowest measured codes); Robertson's own values there are the noise's bias.
        const double low = slope(first, first + 16);
        for (int z = 1; z < first; ++z) next[std::size_t(z)] = next[std::size_t(first)] * std::pow(double(z) / first, low);
        // Above them it keeps the shape of the curve it started from: a bracket that never
        // exposed a pixel well into the shoulder says nothing of it, and a power law there (no
        // shoulder) was 45 % off at code 250 on such a bracket of studio.
        for (int z = last + 1; z < 256; ++z) {
            const double ratio = g[std::size_t(z - 1)] > 0 ? g[std::size_t(z)] / g[std::size_t(z - 1)] : 1.0;
            next[std::size_t(z)] = next[std::size_t(z - 1)] * (std::isfinite(ratio) ? std::max(ratio, 1.0 + 1e-6) : 1.0 + 1e-6);
        }
        next[0] = 0;
        g = next;
        range.low = first;
        range.high = last;
    }
    return g;
}

}  // namespace

ResponseResult calibrate_response(const Session& s) {
    if (s.frames.size() < 3)
        throw InputError(s.dir.string() + ": a response calibration needs a bracket of at least 3 frames");
    std::vector<cv::Mat> images;
    std::vector<float> times;
    std::vector<double> exposures;
    double shortest = 1e30, longest = 0;
    for (const FrameRecord& r : s.frames) {
        const CameraFrame f = load_frame(s, r);
        // One size for the bracket (OpenCV asserts, naming no file, on a frame of another).
        if (!images.empty() && (f.rgb.cols != images.front().cols || f.rgb.rows != images.front().rows))
            throw InputError((s.dir / r.file).string() + ": the image is " + std::to_string(f.rgb.cols) + "x" +
                             std::to_string(f.rgb.rows) + ", the bracket's first frame " +
                             std::to_string(images.front().cols) + "x" + std::to_string(images.front().rows));
        cv::Mat bgr;
        cv::cvtColor(f.rgb, bgr, cv::COLOR_RGB2BGR);
        images.push_back(bgr);
        const double t = r.exposure_s * r.analogue_gain * r.digital_gain;
        times.push_back(float(t));
        exposures.push_back(t);
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
    // A code that never occurs in a channel is NaN in Robertson's curve (its count is 0): a
    // camera's tone curve or digital gain can skip codes. Such codes take the geometric mean of
    // their nearest finite neighbours (or the one there is), so that neither the refinement's
    // extrapolation nor the scale below carries a NaN through the table.
    fill_missing_codes(mean);
    MeasuredCodes measured;
    mean = refine_response(images, exposures, mean, measured);
    // Robertson's curve is defined up to a scale: code 254 (just below clipping) is exposure 1.
    const double scale = std::isfinite(mean[254]) && mean[254] > 0 ? 1.0 / mean[254] : 1.0;
    double previous = 0;
    for (int z = 0; z < 256; ++z) {
        // Strictly increasing, as the table must be: the ends are where the weights are smallest
        // and the estimate is noisiest.
        double v = std::max(0.0, mean[std::size_t(z)] * scale);
        if (z > 0 && v <= previous) v = previous * (1 + 1e-6) + 1e-12;
        out.response.inverse[std::size_t(z)] = v;
        previous = v;
    }
    out.measured_low = measured.low;
    out.measured_high = measured.high;
    out.response.gamma = 0;  // a table only
    out.response.shoulder = 0;
    return out;
}

std::string response_coverage(const ResponseResult& r) {
    if (r.measured_high < r.measured_low)
        return "the bracket measured no code well (Robertson's curve alone): a still view with bright and dark parts, "
               "over at least 100x in exposure";
    std::string text = "codes " + std::to_string(r.measured_low) + ".." + std::to_string(r.measured_high) + " measured";
    // The capture weighs codes by code_weight, small below 32 and above 250.
    if (r.measured_low > 32)
        text += "; below " + std::to_string(r.measured_low) +
                " extrapolated (no pixel read that dark at a known exposure: start the bracket shorter)";
    if (r.measured_high < 250)
        text += "; above " + std::to_string(r.measured_high) +
                " extrapolated (no pixel read that bright at a known exposure: end the bracket longer)";
    return text;
}

NoiseResult calibrate_noise(const Session& s, const CameraCalibration& cal) {
    constexpr double kTopShare = 0.8;
    // Frames in order of exposure x gain.
    std::vector<const FrameRecord*> frames;
    for (const FrameRecord& r : s.frames) frames.push_back(&r);
    const auto exposure = [](const FrameRecord& r) { return r.exposure_s * r.analogue_gain * r.digital_gain; };
    std::sort(frames.begin(), frames.end(),
              [&](const FrameRecord* a, const FrameRecord* b) { return exposure(*a) < exposure(*b); });
    const std::array<double, 256>& inv = cal.response.inverse;
    // Each code's bin width in X, squared over 12: the variance of rounding to that code.
    std::array<double, 256> quantisation{};
    for (int z = 0; z < 256; ++z) {
        const double lo = inv[std::size_t(std::max(0, z - 1))], hi = inv[std::size_t(std::min(255, z + 1))];
        const double width = (hi - lo) / double(std::min(255, z + 1) - std::max(0, z - 1));
        quantisation[std::size_t(z)] = width * width / 12.0;
    }
    // Bins of X by powers of 2^(1/4) from 1e-4 up.
    constexpr int kBins = 56;
    struct Bin {
        long long n = 0;
        double d = 0, d2 = 0, shot = 0, read = 0, quant = 0;
    };
    std::vector<Bin> bins(kBins);
    NoiseResult out;
    std::optional<CameraFrame> previous;
    const FrameRecord* previous_record = nullptr;
    for (const FrameRecord* record : frames) {
        CameraFrame frame = load_frame(s, *record);
        if (previous && frame.rgb.size() == previous->rgb.size()) {
            const double rho = exposure(*record) / exposure(*previous_record);
            const double g1 = record->analogue_gain, g0 = previous_record->analogue_gain;
            if (rho >= 1.2 && rho <= 8) {
                ++out.pairs;
                for (int v = 0; v < frame.rgb.rows; ++v) {
                    const std::uint8_t* a = previous->rgb.ptr<std::uint8_t>(v);
                    const std::uint8_t* b = frame.rgb.ptr<std::uint8_t>(v);
                    for (int q = 0; q < 3 * frame.rgb.cols; ++q) {
                        const int z0 = a[q], z1 = b[q];
                        if (z0 < 2 || z1 < 2 || z0 > 249 || z1 > 249) continue;
                        const double x0 = inv[std::size_t(z0)], x1 = inv[std::size_t(z1)];
                        const double x = 0.5 * (x0 + x1 / rho);  // the earlier frame's exposure
                        if (!(x > 1e-4)) continue;
                        // Near the top the later read is cut at code 249 and spreads less than
                        // the noise: one such bin, of a tiny variance and so a huge weight, turned
                        // a fit's full well negative. Its expected exposure stays below 0.8 of
                        // code 249's.
                        if (rho * x > kTopShare * inv[249]) continue;
                        const int k = int(std::floor(4.0 * std::log2(x / 1e-4)));
                        if (k < 0 || k >= kBins) continue;
                        Bin& bin = bins[std::size_t(k)];
                        const double d = x1 - rho * x0;
                        ++bin.n;
                        bin.d += d;
                        bin.d2 += d * d;
                        bin.shot += rho * x * g1 + rho * rho * x * g0;
                        bin.read += 1 + rho * rho;
                        bin.quant += quantisation[std::size_t(z1)] + rho * rho * quantisation[std::size_t(z0)];
                        ++out.samples;
                    }
                }
            }
        }
        previous = std::move(frame);
        previous_record = record;
    }
    if (out.pairs == 0)
        throw InputError(s.dir.string() + ": a noise calibration needs a bracket of a still view with consecutive "
                                          "exposures 1.2-8x apart (e.g. glint simulate --bracket 12)");
    // Per bin: variance about the bin's mean difference, less the quantisation; the model's two
    // regressors' means. Weighted least squares, each bin's weight n / variance^2 (its variance's
    // relative standard error is sqrt(2 / n)). Only bins of X well above the read noise: below,
    // the codes under 2 that are left out are the reads the noise pushed down, and what is left
    // spreads less than the noise (measured: at X = 1e-3 a third of the variance with a read noise
    // of 2e-3). The threshold starts at 1e-2 and follows the fitted read noise (5 of it).
    struct Row {
        double x, a, b, y, w;
    };
    std::vector<Row> all;
    for (std::size_t k = 0; k < bins.size(); ++k) {
        const Bin& bin = bins[k];
        if (bin.n < 200) continue;
        const double n = double(bin.n);
        const double variance = bin.d2 / n - (bin.d / n) * (bin.d / n) - bin.quant / n;
        if (!(variance > 0)) continue;
        all.push_back({1e-4 * std::exp2((double(k) + 0.5) / 4.0), bin.shot / n, bin.read / n, variance,
                       n / (variance * variance)});
    }
    double inv_full_well = 0, read2 = 0, threshold = 1e-2;
    std::vector<Row> rows;
    for (int pass = 0; pass < 4; ++pass) {
        rows.clear();
        for (const Row& r : all)
            if (r.x >= threshold) rows.push_back(r);
        if (rows.size() < 4)
            throw InputError(s.dir.string() + ": only " + std::to_string(rows.size()) +
                             " exposure bins above the read noise hold enough pixels read in two frames; a noise "
                             "calibration needs a bracket of a view with a range of brightness");
        double saa = 0, sab = 0, sbb = 0, say = 0, sby = 0;
        for (const Row& r : rows) {
            saa += r.w * r.a * r.a;
            sab += r.w * r.a * r.b;
            sbb += r.w * r.b * r.b;
            say += r.w * r.a * r.y;
            sby += r.w * r.b * r.y;
        }
        const double det = saa * sbb - sab * sab;
        inv_full_well = det > 0 ? (say * sbb - sby * sab) / det : 0.0;
        read2 = std::max(0.0, det > 0 ? (saa * sby - sab * say) / det : 0.0);  // 0: below what the bins resolve
        const double next = std::max(1e-2, 5 * std::sqrt(read2));
        if (next <= threshold * 1.01) break;
        threshold = next;
    }
    out.bins = int(rows.size());
    if (!(inv_full_well > 0))
        throw InputError(s.dir.string() + ": the bracket's frames show no shot noise (a noiseless recording?); the "
                                          "noise model cannot be fitted");
    out.full_well_electrons = 1.0 / inv_full_well;
    out.read_noise = std::sqrt(read2);
    double sum = 0;
    for (const Row& r : rows) {
        const double model = inv_full_well * r.a + read2 * r.b;
        sum += (r.y / model - 1) * (r.y / model - 1);
    }
    out.fit_rms = std::sqrt(sum / double(rows.size()));
    // The bins' variances follow the model within a few % on a sensor it describes (1.4-2.7 %
    // on the simulator's); a noiseless recording's leftover rounding gave 780 %.
    if (out.fit_rms > 0.5)
        throw InputError(s.dir.string() + ": the frames' differences do not follow shot and read noise (fit RMS " +
                         std::to_string(int(std::lround(100 * out.fit_rms))) +
                         " % over " + std::to_string(rows.size()) +
                         " exposure bins): a noiseless recording, a view that moved, or a response far off");
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
        if (!f.is(k.width, k.height))
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

namespace {

// The unit quaternion (w >= 0) of the rotation matrix C R C, R an OpenCV 3x3 (row-major) and
// C = diag(c): R seen in axes with some of them turned round.
glm::dquat rotation_of_matrix(const cv::Mat& R, const glm::dvec3& c) {
    glm::dmat3 m(0);
    for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j) m[j][i] = c[i] * R.at<double>(i, j) * c[j];  // GLM: m[column][row]
    return unit_rotation(glm::quat_cast(m));
}

// The rotation R minimising sum w |R a_i - b_i|^2 (Kabsch, by SVD of the 3x3 correlation).
glm::dquat kabsch(const std::vector<glm::dvec3>& a, const std::vector<glm::dvec3>& b) {
    cv::Mat C = cv::Mat::zeros(3, 3, CV_64F);
    for (std::size_t i = 0; i < a.size(); ++i)
        for (int r = 0; r < 3; ++r)
            for (int c = 0; c < 3; ++c) C.at<double>(r, c) += b[i][r] * a[i][c];
    cv::Mat w, u, vt;
    cv::SVD::compute(C, w, u, vt);
    cv::Mat d = cv::Mat::eye(3, 3, CV_64F);
    if (cv::determinant(u * vt) < 0) d.at<double>(2, 2) = -1;
    return rotation_of_matrix(u * d * vt, {1, 1, 1});
}

// What image_rotation measured: the rotation and the correspondences it was fitted to (unit rays
// in each camera and the image row each was seen on, for a rolling shutter's row times).
struct ImageRotation {
    glm::dquat a_from_b{1, 0, 0, 0};
    std::vector<glm::dvec3> rays_a, rays_b;
    std::vector<double> rows_a, rows_b;
};

// The rotation between two frames of a rotating camera, from the images: ORB features, matches,
// a RANSAC homography of the undistorted normalised points, and the nearest rotation to it.
// Returns the rotation taking camera-b vectors into camera-a's frame (a_from_b), in the
// conventions' camera frame (-Z forward, +Y up).
std::optional<ImageRotation> image_rotation(const cv::Mat& a, const cv::Mat& b, const Intrinsics& k) {
    // Small frames and soft indoor texture: smaller patches and a low FAST threshold find enough corners.
    cv::Ptr<cv::ORB> orb = cv::ORB::create(1500, 1.2f, 8, 15, 0, 2, cv::ORB::HARRIS_SCORE, 15, 5);
    std::vector<cv::KeyPoint> ka, kb;
    cv::Mat da, db, ga, gb;
    cv::cvtColor(a, ga, cv::COLOR_RGB2GRAY);
    cv::cvtColor(b, gb, cv::COLOR_RGB2GRAY);
    orb->detectAndCompute(ga, cv::noArray(), ka, da);
    orb->detectAndCompute(gb, cv::noArray(), kb, db);
    if (ka.size() < 30 || kb.size() < 30) return std::nullopt;
    cv::BFMatcher matcher(cv::NORM_HAMMING, true);
    std::vector<cv::DMatch> matches;
    matcher.match(da, db, matches);
    if (matches.size() < 30) return std::nullopt;
    std::vector<cv::Point2d> pa, pb;
    std::vector<glm::dvec3> rays_a, rays_b;
    std::vector<double> row_a, row_b;
    for (const cv::DMatch& m : matches) {
        row_a.push_back(ka[std::size_t(m.queryIdx)].pt.y);
        row_b.push_back(kb[std::size_t(m.trainIdx)].pt.y);
        // Undistorted normalised OpenCV coordinates (x right, y down, z forward).
        const glm::dvec3 ra = pixel_ray(k, ka[std::size_t(m.queryIdx)].pt.x, ka[std::size_t(m.queryIdx)].pt.y);
        const glm::dvec3 rb = pixel_ray(k, kb[std::size_t(m.trainIdx)].pt.x, kb[std::size_t(m.trainIdx)].pt.y);
        pa.emplace_back(ra.x / -ra.z, -ra.y / -ra.z);
        pb.emplace_back(rb.x / -rb.z, -rb.y / -rb.z);
        rays_a.push_back(glm::normalize(ra));
        rays_b.push_back(glm::normalize(rb));
    }
    std::vector<unsigned char> inliers;
    const cv::Mat H = cv::findHomography(pb, pa, cv::RANSAC, 0.002, inliers);  // b -> a
    if (H.empty() || cv::countNonZero(inliers) < 25) return std::nullopt;
    // The homography only picks the inliers: its 8 degrees of freedom trade perspective against
    // rotation over a narrow field of view, and its nearest rotation was 0.5-1 degree off per
    // pair. The rotation itself is fitted to the inliers' rays (Kabsch, a_from_b: ray_a = R ray_b),
    // twice, the second time on the rays within 3x the first fit's median angle (at least 0.002).
    std::vector<glm::dvec3> fa, fb;
    for (std::size_t i = 0; i < inliers.size(); ++i)
        if (inliers[i]) {
            fa.push_back(rays_a[i]);
            fb.push_back(rays_b[i]);
        }
    glm::dquat q = kabsch(fb, fa);
    ImageRotation features;  // the ORB stage's result
    for (int round = 0; round < 2; ++round) {
        std::vector<double> err;
        for (std::size_t i = 0; i < rays_a.size(); ++i)
            err.push_back(std::acos(std::clamp(glm::dot(rays_a[i], q * rays_b[i]), -1.0, 1.0)));
        std::vector<double> sorted;
        for (std::size_t i = 0; i < inliers.size(); ++i)
            if (inliers[i]) sorted.push_back(err[i]);
        std::nth_element(sorted.begin(), sorted.begin() + std::ptrdiff_t(sorted.size() / 2), sorted.end());
        const double cutoff = std::max(3 * sorted[sorted.size() / 2], 0.002);
        fa.clear();
        fb.clear();
        features = {};
        for (std::size_t i = 0; i < rays_a.size(); ++i)
            if (err[i] < cutoff) {
                fa.push_back(rays_a[i]);
                fb.push_back(rays_b[i]);
                features.rows_a.push_back(row_a[i]);
                features.rows_b.push_back(row_b[i]);
            }
        if (fa.size() < 25) return std::nullopt;
        q = kabsch(fb, fa);
    }
    features.a_from_b = q;
    features.rays_a = fa;
    features.rays_b = fb;
    // ORB's keypoints sit on (pyramid) pixels, which left the rotation about 0.1-0.3 degree noisy
    // per pair on noisy frames. Sub-pixel correspondences: corners of a, their place in b predicted
    // by the rotation so far, then refined by normalised cross-correlation of an 11x11 patch over
    // +-3 px and a parabola through the peak; the rotation is fitted to their rays again.
    std::vector<cv::Point2f> ca;
    cv::goodFeaturesToTrack(ga, ca, 600, 0.005, 4);
    if (ca.size() < 30) return features;
    const glm::dquat b_from_a = glm::conjugate(q);
    constexpr int kHalf = 5, kSearch = 3;
    std::vector<cv::Point2f> kept_a, cb;
    for (const cv::Point2f& p : ca) {
        const int ua = int(std::lround(p.x)), va = int(std::lround(p.y));
        if (ua < kHalf || va < kHalf || ua >= k.width - kHalf || va >= k.height - kHalf) continue;
        const auto pb2 = project(k, b_from_a * pixel_ray(k, ua, va), 0.0);
        if (!pb2) continue;
        const int ub = int(std::lround(pb2->u)), vb = int(std::lround(pb2->v));
        const int r = kHalf + kSearch;
        if (ub < r || vb < r || ub >= k.width - r || vb >= k.height - r) continue;
        cv::Mat score;
        cv::matchTemplate(gb(cv::Rect(ub - r, vb - r, 2 * r + 1, 2 * r + 1)),
                          ga(cv::Rect(ua - kHalf, va - kHalf, 2 * kHalf + 1, 2 * kHalf + 1)), score, cv::TM_CCOEFF_NORMED);
        double best_score;
        cv::Point at;
        cv::minMaxLoc(score, nullptr, &best_score, nullptr, &at);
        if (best_score < 0.8 || at.x == 0 || at.y == 0 || at.x == score.cols - 1 || at.y == score.rows - 1) continue;
        const auto peak = [](float l, float c, float rr) {
            const float d = l - 2 * c + rr;
            return d < 0 ? 0.5f * (l - rr) / d : 0.0f;
        };
        const float dx = peak(score.at<float>(at.y, at.x - 1), score.at<float>(at.y, at.x), score.at<float>(at.y, at.x + 1));
        const float dy = peak(score.at<float>(at.y - 1, at.x), score.at<float>(at.y, at.x), score.at<float>(at.y + 1, at.x));
        kept_a.emplace_back(float(ua), float(va));
        cb.emplace_back(float(ub - kSearch + at.x) + dx, float(vb - kSearch + at.y) + dy);
    }
    std::vector<glm::dvec3> la, lb;
    for (std::size_t i = 0; i < kept_a.size(); ++i) {
        la.push_back(glm::normalize(pixel_ray(k, kept_a[i].x, kept_a[i].y)));
        lb.push_back(glm::normalize(pixel_ray(k, cb[i].x, cb[i].y)));
    }
    if (la.size() < 30) return features;
    ImageRotation tracked;
    glm::dquat t = kabsch(lb, la);
    for (int round = 0; round < 2; ++round) {
        std::vector<double> err;
        for (std::size_t i = 0; i < la.size(); ++i)
            err.push_back(std::acos(std::clamp(glm::dot(la[i], t * lb[i]), -1.0, 1.0)));
        std::vector<double> sorted = err;
        std::nth_element(sorted.begin(), sorted.begin() + std::ptrdiff_t(sorted.size() / 2), sorted.end());
        const double cutoff = std::max(3 * sorted[sorted.size() / 2], 0.001);
        std::vector<glm::dvec3> xa, xb;
        tracked = {};
        for (std::size_t i = 0; i < la.size(); ++i)
            if (err[i] < cutoff) {
                xa.push_back(la[i]);
                xb.push_back(lb[i]);
                tracked.rows_a.push_back(kept_a[i].y);
                tracked.rows_b.push_back(cb[i].y);
            }
        if (xa.size() < 30) return features;
        t = kabsch(xb, xa);
        tracked.rays_a = std::move(xa);
        tracked.rays_b = std::move(xb);
    }
    tracked.a_from_b = t;
    // A tracked rotation far from the features' one is a failed track: keep the features'.
    return angle_between(t, q) < 1.0 * kPi / 180 ? tracked : features;
}

}  // namespace

AlignmentResult calibrate_alignment(const Session& s, double max_offset_s) {
    if (s.sensors.empty()) throw InputError(s.dir.string() + ": an alignment needs the session's sensor recording");
    return calibrate_alignment(s, load_sensor_orientations(s), max_offset_s);
}

// A pair whose residual is over 3x the median (and over 0.5 degrees) is an outlier (a wrong
// homography): the refinement leaves it out, and so does the mounting's information.
static double outlier_cutoff_rad(double median_residual_rad) {
    return std::max(3 * median_residual_rad, 0.5 * kPi / 180);
}

namespace {

// An image rotation between consecutive frames, with their times.
struct AlignmentPair {
    std::int64_t ta, tb;
    glm::dquat camera_a_from_b;
    ImageRotation seen;  // the correspondences, for the rolling shutter's row times
};

// What an alignment is solved from: the sensor's orientations and the frames' image rotations.
struct AlignmentInputs {
    std::unique_ptr<host::OrientationHistory> history;
    std::vector<AlignmentPair> pairs;
};

AlignmentInputs measure_alignment(const Session& s, const std::vector<SensorOrientation>& orientations) {
    if (orientations.size() < 2) throw InputError(s.dir.string() + ": an alignment needs the sensor's orientations");
    AlignmentInputs in;
    in.history = std::make_unique<host::OrientationHistory>(orientations.size() + 1, 100'000'000, 0);
    for (const SensorOrientation& x : orientations) in.history->push({x.t_ns, x.world_from_sensor, 0});
    // Image rotations between consecutive frames.
    std::vector<AlignmentPair>& pairs = in.pairs;
    CameraFrame previous;
    bool have_previous = false;
    for (const FrameRecord& r : s.frames) {
        CameraFrame f = load_frame(s, r);
        check_frame_size(s, r, f);  // the rotation is read through the calibration's intrinsics
        if (have_previous) {
            if (auto q = image_rotation(previous.rgb, f.rgb, s.calibration.intrinsics))
                if (angle_between(q->a_from_b, glm::dquat(1, 0, 0, 0)) > 2 * kPi / 180)  // too small a turn says little
                    pairs.push_back({previous.t_ns, f.t_ns, q->a_from_b, std::move(*q)});
        }
        previous = std::move(f);
        have_previous = true;
    }
    if (pairs.size() < 10)
        throw InputError(s.dir.string() + ": only " + std::to_string(pairs.size()) +
                         " frame pairs with a measurable turn; the alignment needs a scan");
    return in;
}

// The alignment from measured pairs, the rows read out over readout_s (0: a global shutter).
// trimmed_cost (optional): the sum of the squared residual angles (rad^2) of the best 80 % of
// the pairs at the solution, and trimmed_count their number: what calibrate_readout compares.
AlignmentResult solve_alignment(const Session& s, const host::OrientationHistory& history,
                                std::vector<AlignmentPair> pairs, double readout_s, double max_offset_s,
                                double* trimmed_cost = nullptr, int* trimmed_count = nullptr) {
    using Pair = AlignmentPair;
    // The sensor's relative rotation over a pair at a time offset (ns), or nothing outside the stream.
    const auto sensor_rel_at = [&](const Pair& p, double off_ns) -> std::optional<glm::dquat> {
        const auto qa = history.at(p.ta + std::int64_t(std::llround(off_ns))).world_from_sensor;
        const auto qb = history.at(p.tb + std::int64_t(std::llround(off_ns))).world_from_sensor;
        if (!qa || !qb) return std::nullopt;
        return unit_rotation(glm::conjugate(*qa) * *qb);  // sensor a_from_b
    };
    // 1. A coarse search: for each offset on a 1 ms grid, the mounting from Kabsch and the median
    //    residual; the offset with the smallest median wins.
    AlignmentResult best;
    best.residual_deg = 1e9;
    const int steps = int(std::lround(max_offset_s * 1000));
    for (int ms = -steps; ms <= steps; ++ms) {
        const double off = double(ms) * 1e6;
        // Relative rotations: camera a_from_b = X^-1 (sensor a_from_b) X, with X = sensor_from_camera,
        // so their rotation vectors satisfy v_camera = X^-1 v_sensor: fit X^-1 on the pairs.
        std::vector<glm::dvec3> vs, vc;
        std::vector<glm::dquat> sensor_rel, camera_rel;
        for (const Pair& p : pairs) {
            const auto sens = sensor_rel_at(p, off);
            if (!sens) continue;
            vs.push_back(rotation_vector(*sens));
            vc.push_back(rotation_vector(p.camera_a_from_b));
            sensor_rel.push_back(*sens);
            camera_rel.push_back(p.camera_a_from_b);
        }
        if (vs.size() < 10) continue;
        const glm::dquat camera_from_sensor = kabsch(vs, vc);
        const glm::dquat x = glm::conjugate(camera_from_sensor);  // sensor_from_camera
        std::vector<double> res;
        for (std::size_t i = 0; i < vs.size(); ++i) {
            const glm::dquat predicted = unit_rotation(glm::conjugate(x) * sensor_rel[i] * x);
            res.push_back(angle_between(predicted, camera_rel[i]) * 180 / kPi);
        }
        std::nth_element(res.begin(), res.begin() + std::ptrdiff_t(res.size() / 2), res.end());
        const double median = res[res.size() / 2];
        if (median < best.residual_deg) {
            best.residual_deg = median;
            best.sensor_from_camera = x;
            best.time_offset_s = double(ms) * 1e-3;
            best.pairs = int(vs.size());
        }
    }
    if (best.residual_deg >= 1e9)
        throw InputError(s.dir.string() + ": the sensor recording does not cover the frames' pairs");
    // 2. A joint refinement of the mounting and the offset (continuous): Gauss-Newton with
    //    Levenberg damping on the residual vectors r_i = log(C_i^-1 X^-1 S_i(offset) X), the
    //    mounting updated as X exp(d). Pairs whose residual is over 3x the median (and over
    //    0.5 degrees) are outliers (a wrong homography) and left out, re-decided each round.
    glm::dquat x = best.sensor_from_camera;
    double off_ns = best.time_offset_s * 1e9;
    const auto residual = [&](const Pair& p, const glm::dquat& xq, double o) -> std::optional<glm::dvec3> {
        const auto sens = sensor_rel_at(p, o);
        if (!sens) return std::nullopt;
        return rotation_vector(unit_rotation(glm::conjugate(p.camera_a_from_b) * glm::conjugate(xq) * *sens * xq));
    };
    const auto cost_of = [&](const glm::dquat& xq, double o, double cutoff, int* used) {
        double c = 0;
        int n = 0;
        for (const Pair& p : pairs) {
            const auto r = residual(p, xq, o);
            if (!r) continue;
            const double a = glm::length(*r);
            if (a > cutoff) continue;
            c += glm::dot(*r, *r);
            ++n;
        }
        if (used) *used = n;
        return c;
    };
    // Normal equations J^T J and J^T r of the residuals within `cutoff` at (xq, o), from a
    // numerical Jacobian of 4 parameters: d of the mounting (xq exp(d), radians) and the offset
    // (ms). The refinement steps with them; at the end they are the information about the
    // mounting and the offset together.
    const double dt_scale = 1e6;  // the offset's parameter in ms
    const auto normal_equations = [&](const glm::dquat& xq, double o, double cutoff, cv::Matx44d& JtJ, cv::Vec4d& Jtr) {
        JtJ = cv::Matx44d::zeros();
        Jtr = cv::Vec4d(0, 0, 0, 0);
        const double h = 1e-5, h_ms = 0.25;
        for (const Pair& p : pairs) {
            const auto r0 = residual(p, xq, o);
            if (!r0 || glm::length(*r0) > cutoff) continue;
            glm::dvec3 J[4];
            bool ok = true;
            for (int k = 0; k < 4 && ok; ++k) {
                glm::dvec3 dv(0);
                double dt = 0;
                if (k < 3) dv[k] = h;
                else dt = h_ms * dt_scale;
                const glm::dquat xp = k < 3 ? unit_rotation(xq * rotation_from_vector(dv)) : xq;
                const glm::dquat xm = k < 3 ? unit_rotation(xq * rotation_from_vector(-dv)) : xq;
                const auto rp = residual(p, xp, o + dt), rm = residual(p, xm, o - dt);
                if (!rp || !rm) ok = false;
                else J[k] = (*rp - *rm) / (2 * (k < 3 ? h : h_ms));
            }
            if (!ok) continue;
            for (int a = 0; a < 4; ++a) {
                Jtr[a] += glm::dot(J[a], *r0);
                for (int b = 0; b < 4; ++b) JtJ(a, b) += glm::dot(J[a], J[b]);
            }
        }
    };
    const auto refine = [&] {
        double lambda = 1e-3;
        for (int round = 0; round < 30; ++round) {
            // The outlier cutoff at the current estimate.
            std::vector<double> angles;
            for (const Pair& p : pairs)
                if (const auto r = residual(p, x, off_ns)) angles.push_back(glm::length(*r));
            if (angles.size() < 10) break;
            std::nth_element(angles.begin(), angles.begin() + std::ptrdiff_t(angles.size() / 2), angles.end());
            const double cutoff = outlier_cutoff_rad(angles[angles.size() / 2]);
            // Normal equations from a numerical Jacobian (4 parameters: d of the mounting, offset).
            cv::Matx44d JtJ;
            cv::Vec4d Jtr;
            normal_equations(x, off_ns, cutoff, JtJ, Jtr);
            const double before = cost_of(x, off_ns, cutoff, nullptr);
            bool improved = false;
            for (int tries = 0; tries < 8 && !improved; ++tries) {
                cv::Matx44d A = JtJ;
                for (int a = 0; a < 4; ++a) A(a, a) *= 1 + lambda;
                cv::Vec4d step;
                if (!cv::solve(A, -Jtr, step, cv::DECOMP_CHOLESKY)) break;
                const glm::dquat xn = unit_rotation(x * rotation_from_vector({step[0], step[1], step[2]}));
                const double on = std::clamp(off_ns + step[3] * dt_scale, -max_offset_s * 1e9, max_offset_s * 1e9);
                if (cost_of(xn, on, cutoff, nullptr) < before) {
                    const bool small = cv::norm(cv::Vec3d(step[0], step[1], step[2])) < 1e-7 && std::abs(step[3]) < 1e-4;
                    x = xn;
                    off_ns = on;
                    lambda = std::max(1e-7, lambda / 10);
                    improved = true;
                    if (small) round = 1000;  // converged
                } else {
                    lambda *= 10;
                }
            }
            if (!improved) break;
        }
    };
    refine();
    // 3. A rolling shutter (calibration readout_s) sees each row at its own time: a pitching
    //    camera's features move between rows, so the image rotation comes out scaled (about 2 %
    //    at 52 deg/s with a 20 ms readout), and the offset and mounting take that in. Each pair's
    //    rays are turned to their frame's mid time with the camera's angular velocity (the
    //    sensor's, through the mounting and offset found so far: r_mid = exp(w dt_row) r) and the
    //    rotation fitted again, then the refinement runs again; twice, as the mounting moves.
    CameraCalibration cal = s.calibration;
    cal.readout_s = readout_s;
    if (cal.readout_s > 0) {
        const auto camera_rate = [&](std::int64_t t_ns, const glm::dquat& xq, double o) -> std::optional<glm::dvec3> {
            const std::int64_t h = 10'000'000;  // +-10 ms: a few sensor samples, the turn nearly steady
            const auto q0 = history.at(t_ns + std::int64_t(std::llround(o)) - h).world_from_sensor;
            const auto q1 = history.at(t_ns + std::int64_t(std::llround(o)) + h).world_from_sensor;
            if (!q0 || !q1) return std::nullopt;
            const glm::dvec3 sensor_rate = rotation_vector(unit_rotation(glm::conjugate(*q0) * *q1)) / (2e-9 * double(h));
            return glm::conjugate(xq) * sensor_rate;  // into the camera's frame
        };
        for (int pass = 0; pass < 2; ++pass) {
            for (Pair& p : pairs) {
                const auto wa = camera_rate(p.ta, x, off_ns), wb = camera_rate(p.tb, x, off_ns);
                if (!wa || !wb) continue;
                std::vector<glm::dvec3> ra, rb;
                for (std::size_t i = 0; i < p.seen.rays_a.size(); ++i) {
                    ra.push_back(rotation_from_vector(*wa * cal.row_time_offset_s(p.seen.rows_a[i])) * p.seen.rays_a[i]);
                    rb.push_back(rotation_from_vector(*wb * cal.row_time_offset_s(p.seen.rows_b[i])) * p.seen.rays_b[i]);
                }
                if (ra.size() >= 10) p.camera_a_from_b = kabsch(rb, ra);
            }
            refine();
        }
    }
    // The refined estimate, with the median residual and the pairs used (within the cutoff).
    std::vector<double> angles;
    for (const Pair& p : pairs)
        if (const auto r = residual(p, x, off_ns)) angles.push_back(glm::length(*r) * 180 / kPi);
    if (angles.size() >= 10) {
        std::nth_element(angles.begin(), angles.begin() + std::ptrdiff_t(angles.size() / 2), angles.end());
        best.sensor_from_camera = unit_rotation(x);
        best.time_offset_s = off_ns * 1e-9;
        best.residual_deg = angles[angles.size() / 2];
        best.pairs = int(angles.size());
    }
    // How well the motion pins the mounting down. Turning the mounting by a small d moves a pair's
    // residual by about d x c (c the pair's rotation vector in the camera), so the information
    // about the mounting is about sum (|c|^2 I - c c^T) / sigma^2: about an axis the pairs turned
    // round and round but never away from, almost none. A motion about too few axes (a recording
    // cut off after the first turns) gave a median residual of 0.09 degrees and a mounting 13.6
    // degrees off. The information is the refinement's own (the numerical Jacobian of the
    // mounting and the offset at the estimate), and the offset is marginalised out (the Schur
    // complement of its entry): a turn of the mounting that a shift of the offset could take up
    // is not counted as pinned down.
    {
        const double cutoff = outlier_cutoff_rad(best.residual_deg * kPi / 180);
        cv::Matx44d JtJ;
        cv::Vec4d Jtr;
        normal_equations(x, off_ns, cutoff, JtJ, Jtr);
        cv::Matx33d info;
        for (int r = 0; r < 3; ++r)
            for (int c = 0; c < 3; ++c)
                info(r, c) = JtJ(r, c) - (JtJ(3, 3) > 0 ? JtJ(r, 3) * JtJ(3, c) / JtJ(3, 3) : 0.0);
        cv::Matx31d values;
        cv::Matx33d vectors;
        cv::eigen(info, values, vectors);  // descending
        // A residual vector's components' sigma from its length's median (a 3D Gaussian's length
        // has its median at 1.538 sigma), at least 0.01 degrees (a twentieth of a pixel at 320
        // pixels over 70 degrees: what the image rotations resolve), so that a noiseless session
        // turning about one axis is still caught.
        const double sigma = std::max(best.residual_deg / 1.538, 0.01) * kPi / 180;
        const double weakest = values(2);
        best.mounting_sd_deg = weakest > 0 ? sigma / std::sqrt(weakest) * 180 / kPi : 1e9;
        best.weakest_axis = glm::dvec3(vectors(2, 0), vectors(2, 1), vectors(2, 2));
    }
    if (trimmed_cost) {
        std::vector<double> squares;
        for (const Pair& p : pairs)
            if (const auto r = residual(p, x, off_ns)) squares.push_back(glm::dot(*r, *r));
        std::sort(squares.begin(), squares.end());
        squares.resize(squares.size() * 4 / 5);
        *trimmed_cost = 0;
        for (double q : squares) *trimmed_cost += q;
        if (trimmed_count) *trimmed_count = int(squares.size());
    }
    return best;
}

}  // namespace

AlignmentResult calibrate_alignment(const Session& s, const std::vector<SensorOrientation>& orientations,
                                    double max_offset_s) {
    AlignmentInputs in = measure_alignment(s, orientations);
    return solve_alignment(s, *in.history, std::move(in.pairs), s.calibration.readout_s, max_offset_s);
}

namespace {

// The mean of the lowest 80 % of chi-square values of 3 degrees of freedom over their mean: the
// trimmed cost's residuals spread this much less than all of them.
constexpr double kTrimmedChi2Ratio = 0.6735;
// The grid is searched in spans of this much, a span more while the best readout is the last
// searched, up to the longest asked for.
constexpr double kReadoutSpanS = 0.05;

struct ReadoutFit {
    ReadoutResult result;
    bool shown = false;  // the motion shows the readout; else `why` says what it lacked
    std::string why;
};

ReadoutFit fit_readout(const Session& s, const AlignmentInputs& in, double max_readout_s, double max_offset_s) {
    struct Sample {
        double readout_s, mean;  // the trimmed residuals' mean square (rad^2): counts may differ
    };
    const auto solve_at = [&](double readout) {
        double cost = 0;
        int count = 0;
        solve_alignment(s, *in.history, in.pairs, readout, max_offset_s, &cost, &count);
        return Sample{readout, count > 0 ? cost / count : INFINITY};
    };
    std::vector<Sample> grid;
    std::size_t best = 0;
    double searched = 0;
    while (searched < max_readout_s * (1 - 1e-9) && (grid.empty() || best + 1 == grid.size())) {
        const double upto = std::min(max_readout_s, searched + kReadoutSpanS);
        const int steps = std::max(1, int(std::ceil((upto - searched) / kReadoutGridS - 1e-9)));
        for (int k = grid.empty() ? 0 : 1; k <= steps; ++k) grid.push_back(solve_at(searched + (upto - searched) * k / steps));
        searched = upto;
        for (std::size_t k = 1; k < grid.size(); ++k)
            if (grid[k].mean < grid[best].mean) best = k;
    }
    ReadoutFit fit;
    char buf[240];
    if (grid.size() < 3) {
        fit.why = ": too few readouts searched";
        return fit;
    }
    if (best + 1 == grid.size()) {  // still falling at the longest readout searched
        std::snprintf(buf, sizeof buf, ": the readout is %.0f ms or longer, the longest searched", 1e3 * searched);
        fit.why = buf;
        return fit;
    }
    // A parabola through the best point and its neighbours (at 0: the next two).
    const std::size_t mid = std::max<std::size_t>(best, 1);
    const Sample &a = grid[mid - 1], &b = grid[mid], &c = grid[mid + 1];
    const double h = b.readout_s - a.readout_s;
    // m(r) = m_b + g (r - r_b) + q (r - r_b)^2 through the three.
    const double g = (c.mean - a.mean) / (2 * h), q = (c.mean - 2 * b.mean + a.mean) / (2 * h * h);
    const double readout = q > 0 ? std::clamp(b.readout_s - g / (2 * q), a.readout_s, c.readout_s) : grid[best].readout_s;
    double cost = 0;
    int count = 0;
    fit.result.alignment = solve_alignment(s, *in.history, in.pairs, readout, max_offset_s, &cost, &count);
    fit.result.readout_s = readout;
    fit.result.pairs = count;
    // The sum S = count m of 3 count squared components, each of variance sigma^2 (the trimmed
    // mean square, corrected for the trimming, over 3): S = S_min + count q (r - r*)^2, so the
    // readout's variance is sigma^2 / (count q).
    const double sigma2 = count > 0 ? cost / count / (3.0 * kTrimmedChi2Ratio) : INFINITY;
    fit.result.sd_s = q > 0 && count > 0 ? std::sqrt(sigma2 / (count * q)) : INFINITY;
    fit.shown = fit.result.sd_s <= kMaxReadoutSdS;
    if (!fit.shown) {
        std::snprintf(buf, sizeof buf, ": the motion does not show the rolling shutter's readout (best %.1f ms, standard "
                      "deviation %.1f ms, at most %.1f)", 1e3 * readout, 1e3 * fit.result.sd_s, 1e3 * kMaxReadoutSdS);
        fit.why = buf;
    }
    return fit;
}

void check_readout_span(double max_readout_s) {
    if (!(max_readout_s > 0) || !(max_readout_s <= 1))
        throw InputError("the longest readout to search must be in (0, 1] s, not " + std::to_string(max_readout_s));
}

}  // namespace

ReadoutResult calibrate_readout(const Session& s, double max_readout_s, double max_offset_s) {
    if (s.sensors.empty()) throw InputError(s.dir.string() + ": a readout calibration needs the session's sensor recording");
    return calibrate_readout(s, load_sensor_orientations(s), max_readout_s, max_offset_s);
}

ReadoutResult calibrate_readout(const Session& s, const std::vector<SensorOrientation>& orientations,
                                double max_readout_s, double max_offset_s) {
    check_readout_span(max_readout_s);
    const ReadoutFit fit = fit_readout(s, measure_alignment(s, orientations), max_readout_s, max_offset_s);
    if (!fit.shown)
        throw InputError(s.dir.string() + fit.why +
                         ": turn the camera up and down (pitch) and about its lens, at speed");
    return fit.result;
}

AlignmentAndReadout calibrate_alignment_and_readout(const Session& s,
                                                    const std::vector<SensorOrientation>& orientations,
                                                    double max_readout_s, double max_offset_s) {
    check_readout_span(max_readout_s);
    const AlignmentInputs in = measure_alignment(s, orientations);
    ReadoutFit fit = fit_readout(s, in, max_readout_s, max_offset_s);
    AlignmentAndReadout out;
    if (fit.shown) {
        out.alignment = fit.result.alignment;
        out.readout = fit.result;
    } else {
        // The pairs measured once: the alignment at the readout in force.
        out.alignment = solve_alignment(s, *in.history, in.pairs, s.calibration.readout_s, max_offset_s);
        out.readout_refused = fit.why.substr(2);  // without the leading ": "
    }
    return out;
}

void check_alignment_usable(const AlignmentResult& r, const std::string& where) {
    // Noise alone leaves more than the target about that axis: keeping the calibration in force is
    // better than writing this one. (The benchmark's three-axis motions pin it to 0.03-0.06
    // degrees and are 0.07-0.26 degrees off; a single-axis scan or a motion cut off after its
    // first turns leaves degrees.)
    if (!(r.mounting_sd_deg > kMaxMountingSdDeg)) return;
    char buf[320];
    std::snprintf(buf, sizeof buf,
                  ": the motion turned too little about the camera's axis (%+.2f %+.2f %+.2f): it pins the mounting "
                  "down only to %.2f degrees there (at most %.2f); turn the camera about all three axes",
                  r.weakest_axis.x, r.weakest_axis.y, r.weakest_axis.z, r.mounting_sd_deg, kMaxMountingSdDeg);
    throw InputError(where + buf);
}

}  // namespace glint::capture
