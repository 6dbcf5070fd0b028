// One camera frame as every camera source (libcamera, replay, simulator) delivers it.
#pragma once

#include <cstdint>

#include <opencv2/core.hpp>

namespace glint::capture {

struct CameraFrame {
    cv::Mat rgb;                    // CV_8UC3, R G B order, width x height of the stream
    std::int64_t t_ns = 0;          // appliance CLOCK_MONOTONIC at the middle of the exposure
    double exposure_s = 0;          // exposure time, seconds
    double analogue_gain = 1;       // sensor gain (1 = none)
    double digital_gain = 1;        // ISP gain after the sensor (1 = none)
    std::uint64_t sequence = 0;     // frame counter of the source; a gap means dropped frames

    double total_gain() const { return analogue_gain * digital_gain; }
    // 8-bit RGB of width x height (a calibration's size): what every reader that indexes a frame
    // by its calibration needs.
    bool is(int width, int height) const { return rgb.type() == CV_8UC3 && rgb.cols == width && rgb.rows == height; }
};

}  // namespace glint::capture
