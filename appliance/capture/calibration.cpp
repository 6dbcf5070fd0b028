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

}  // namespace glint::capture
