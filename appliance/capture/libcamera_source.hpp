// The real camera through libcamera (0.0.3, Debian 12): one viewfinder stream, RGB at the
// requested size, auto or manual exposure (AeEnable, ExposureTime, AnalogueGain), per-frame
// metadata (SensorTimestamp, ExposureTime, AnalogueGain, DigitalGain), and recovery from a stalled
// pipeline by stopping and restarting the camera. See docs/capture.md "Camera sources".
#pragma once

#include <condition_variable>
#include <deque>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "appliance/capture/camera_source.hpp"

namespace libcamera {
class Camera;
class CameraManager;
class FrameBufferAllocator;
class Request;
class Stream;
}  // namespace libcamera

namespace glint::capture {

struct LibcameraOptions {
    std::string camera_id;        // "" = the first camera libcamera lists
    int width = 1280, height = 720;
    int buffers = 4;
    std::chrono::milliseconds restart_after{1000};  // no frame for this long: restart the camera
};

// Every camera libcamera finds, one line each ("id (model)"); empty when there is none. Throws
// CameraError when libcamera cannot start.
std::vector<std::string> list_libcamera_cameras();

class LibcameraSource final : public CameraSource {
public:
    explicit LibcameraSource(LibcameraOptions options = {});
    ~LibcameraSource() override;
    std::string describe() const override;
    // Throws CameraError naming what libcamera found when the camera is missing, busy or cannot
    // give an RGB stream.
    void start() override;
    void stop() override;
    std::optional<CameraFrame> next_frame(std::chrono::milliseconds timeout) override;
    void set_exposure(const ExposureRequest& request) override;
    CameraHealth health() const override;

private:
    struct Mapped {
        void* data = nullptr;
        std::size_t length = 0;
    };
    void open_and_stream();
    void on_request_completed(libcamera::Request* request);
    void queue(libcamera::Request* request);
    void start_streaming();
    void stop_streaming();
    CameraFrame convert(libcamera::Request* request);

    LibcameraOptions options_;
    std::shared_ptr<libcamera::CameraManager> manager_;  // shared: libcamera allows one per process
    bool acquired_ = false;
    std::shared_ptr<libcamera::Camera> camera_;
    std::unique_ptr<libcamera::FrameBufferAllocator> allocator_;
    libcamera::Stream* stream_ = nullptr;
    std::vector<std::unique_ptr<libcamera::Request>> requests_;
    std::vector<Mapped> mapped_;  // per buffer (one plane each)
    std::string description_;
    std::uint32_t pixel_format_ = 0;  // fourcc of the configured stream
    unsigned stride_ = 0;
    bool streaming_ = false;

    mutable std::mutex mutex_;
    std::condition_variable ready_;
    std::deque<libcamera::Request*> completed_;
    ExposureRequest exposure_;
    CameraHealth health_;
    std::uint64_t last_sequence_ = 0;
    bool have_sequence_ = false;
    std::chrono::steady_clock::time_point last_frame_;
};

}  // namespace glint::capture
