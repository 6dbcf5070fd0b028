#include "appliance/capture/libcamera_source.hpp"

#include <stdlib.h>
#include <sys/mman.h>
#include <time.h>

#include <cstring>
#include <mutex>

#include <libcamera/libcamera.h>

namespace glint::capture {

namespace {

std::int64_t clock_ns(clockid_t id) {
    timespec t{};
    clock_gettime(id, &t);
    return std::int64_t(t.tv_sec) * 1'000'000'000 + t.tv_nsec;
}

std::string camera_name(const libcamera::Camera& camera) {
    const auto model = camera.properties().get(libcamera::properties::Model);
    return camera.id() + (model ? " (" + *model + ")" : "");
}

std::string found_list(const std::vector<std::shared_ptr<libcamera::Camera>>& cameras) {
    if (cameras.empty()) return "libcamera found no camera";
    std::string s = "libcamera found:";
    for (const auto& c : cameras) s += " " + camera_name(*c) + ";";
    return s;
}

}  // namespace

// libcamera allows one CameraManager per process (a second one is a fatal error inside
// libcamera), so every user shares this one; it stops when the last user lets go.
std::shared_ptr<libcamera::CameraManager> shared_camera_manager() {
    static std::mutex mutex;
    static std::weak_ptr<libcamera::CameraManager> current;
    const std::lock_guard lock(mutex);
    if (auto alive = current.lock()) return alive;
    // libcamera logs INFO and WARN lines on stderr by default; the appliance keeps its stderr for
    // its own one-line errors. A technician's LIBCAMERA_LOG_LEVELS still wins.
    setenv("LIBCAMERA_LOG_LEVELS", "*:ERROR", 0);
    auto* raw = new libcamera::CameraManager();
    if (const int err = raw->start(); err != 0) {
        delete raw;
        throw CameraError("libcamera: the camera manager did not start (" + std::string(std::strerror(-err)) + ")");
    }
    std::shared_ptr<libcamera::CameraManager> manager(raw, [](libcamera::CameraManager* m) {
        m->stop();
        delete m;
    });
    current = manager;
    return manager;
}

std::vector<std::string> list_libcamera_cameras() {
    std::vector<std::string> out;
    for (const auto& c : shared_camera_manager()->cameras()) out.push_back(camera_name(*c));
    return out;
}

LibcameraSource::LibcameraSource(LibcameraOptions options) : options_(std::move(options)) {}

LibcameraSource::~LibcameraSource() { stop(); }

std::string LibcameraSource::describe() const { return description_.empty() ? "libcamera (not started)" : description_; }

void LibcameraSource::start() {
    if (camera_) return;
    try {
        open_and_stream();
    } catch (...) {
        stop();  // whatever was opened, mapped or acquired is released before the error leaves
        throw;
    }
}

void LibcameraSource::open_and_stream() {
    manager_ = shared_camera_manager();
    const auto cameras = manager_->cameras();
    if (cameras.empty()) throw CameraError("libcamera: no camera (" + found_list(cameras) + ")");
    camera_ = options_.camera_id.empty() ? cameras.front() : manager_->get(options_.camera_id);
    if (!camera_) throw CameraError("libcamera: no camera '" + options_.camera_id + "' (" + found_list(cameras) + ")");
    if (camera_->acquire() != 0) throw CameraError("libcamera: camera " + camera_name(*camera_) + " is in use by another process");
    acquired_ = true;
    std::unique_ptr<libcamera::CameraConfiguration> config =
        camera_->generateConfiguration({libcamera::StreamRole::Viewfinder});
    if (!config || config->size() != 1) throw CameraError("libcamera: " + camera_name(*camera_) + " offers no viewfinder stream");
    libcamera::StreamConfiguration& cfg = config->at(0);
    // BGR888 is R, G, B in memory (DRM fourcc order); RGB888 is B, G, R; XRGB8888 is B, G, R, X.
    const libcamera::PixelFormat wanted[] = {libcamera::formats::BGR888, libcamera::formats::RGB888,
                                             libcamera::formats::XRGB8888};
    bool found = false;
    for (const libcamera::PixelFormat& f : wanted) {
        const auto offered = cfg.formats().pixelformats();
        if (std::find(offered.begin(), offered.end(), f) != offered.end()) {
            cfg.pixelFormat = f;
            found = true;
            break;
        }
    }
    if (!found) throw CameraError("libcamera: " + camera_name(*camera_) + " offers no 24/32-bit RGB viewfinder format");
    cfg.size = {unsigned(options_.width), unsigned(options_.height)};
    cfg.bufferCount = unsigned(options_.buffers);
    if (config->validate() == libcamera::CameraConfiguration::Invalid)
        throw CameraError("libcamera: " + camera_name(*camera_) + " rejects " + cfg.toString());
    if (camera_->configure(config.get()) != 0)
        throw CameraError("libcamera: configuring " + camera_name(*camera_) + " as " + cfg.toString() + " failed");
    stream_ = cfg.stream();
    pixel_format_ = cfg.pixelFormat.fourcc();
    stride_ = cfg.stride;
    description_ = "libcamera: " + camera_name(*camera_) + " " + cfg.toString();

    allocator_ = std::make_unique<libcamera::FrameBufferAllocator>(camera_);
    if (allocator_->allocate(stream_) < 0) throw CameraError("libcamera: cannot allocate buffers for " + description_);
    for (const std::unique_ptr<libcamera::FrameBuffer>& buffer : allocator_->buffers(stream_)) {
        const libcamera::FrameBuffer::Plane& plane = buffer->planes().front();
        const std::size_t length = plane.length + (plane.offset == libcamera::FrameBuffer::Plane::kInvalidOffset ? 0 : plane.offset);
        void* data = mmap(nullptr, length, PROT_READ, MAP_SHARED, plane.fd.get(), 0);
        if (data == MAP_FAILED) throw CameraError("libcamera: cannot map a frame buffer of " + description_);
        buffer->setCookie(mapped_.size());
        mapped_.push_back({data, length});
        std::unique_ptr<libcamera::Request> request = camera_->createRequest();
        if (!request || request->addBuffer(stream_, buffer.get()) != 0)
            throw CameraError("libcamera: cannot create a request for " + description_);
        requests_.push_back(std::move(request));
    }
    camera_->requestCompleted.connect(this, &LibcameraSource::on_request_completed);
    start_streaming();
}

void LibcameraSource::start_streaming() {
    libcamera::ControlList controls(camera_->controls());
    if (camera_->start(&controls) != 0) throw CameraError("libcamera: cannot start " + description_);
    streaming_ = true;
    last_frame_ = std::chrono::steady_clock::now();
    for (auto& r : requests_) queue(r.get());
}

void LibcameraSource::stop_streaming() {
    if (!streaming_) return;
    camera_->stop();  // completes every queued request as cancelled
    streaming_ = false;
    const std::lock_guard lock(mutex_);
    completed_.clear();
}

void LibcameraSource::queue(libcamera::Request* request) {
    ExposureRequest e;
    {
        const std::lock_guard lock(mutex_);
        e = exposure_;
    }
    libcamera::ControlList& c = request->controls();
    c.set(libcamera::controls::AeEnable, e.automatic);
    if (!e.automatic) {
        c.set(libcamera::controls::ExposureTime, std::int32_t(e.exposure_s * 1e6));
        c.set(libcamera::controls::AnalogueGain, float(e.analogue_gain));
    }
    camera_->queueRequest(request);
}

void LibcameraSource::on_request_completed(libcamera::Request* request) {
    if (request->status() == libcamera::Request::RequestCancelled) return;
    {
        const std::lock_guard lock(mutex_);
        completed_.push_back(request);
    }
    ready_.notify_one();
}

CameraFrame LibcameraSource::convert(libcamera::Request* request) {
    CameraFrame f;
    libcamera::FrameBuffer* buffer = request->findBuffer(stream_);
    const Mapped& m = mapped_[std::size_t(buffer->cookie())];
    const libcamera::FrameBuffer::Plane& plane = buffer->planes().front();
    const auto* base = static_cast<const std::uint8_t*>(m.data) +
                       (plane.offset == libcamera::FrameBuffer::Plane::kInvalidOffset ? 0 : plane.offset);
    const libcamera::StreamConfiguration& cfg = stream_->configuration();
    const int w = int(cfg.size.width), h = int(cfg.size.height);
    f.rgb.create(h, w, CV_8UC3);
    const bool four = pixel_format_ == libcamera::formats::XRGB8888.fourcc();
    const bool bgr_memory = pixel_format_ != libcamera::formats::BGR888.fourcc();
    for (int y = 0; y < h; ++y) {
        const std::uint8_t* src = base + std::size_t(y) * stride_;
        std::uint8_t* dst = f.rgb.ptr<std::uint8_t>(y);
        for (int x = 0; x < w; ++x) {
            const std::uint8_t* p = src + x * (four ? 4 : 3);
            dst[3 * x + 0] = bgr_memory ? p[2] : p[0];
            dst[3 * x + 1] = p[1];
            dst[3 * x + 2] = bgr_memory ? p[0] : p[2];
        }
    }
    const libcamera::ControlList& md = request->metadata();
    const auto exposure_us = md.get(libcamera::controls::ExposureTime);
    const auto again = md.get(libcamera::controls::AnalogueGain);
    const auto dgain = md.get(libcamera::controls::DigitalGain);
    const auto sensor_ts = md.get(libcamera::controls::SensorTimestamp);
    f.exposure_s = exposure_us ? *exposure_us * 1e-6 : 0;
    f.analogue_gain = again ? *again : 1.0;
    f.digital_gain = dgain ? *dgain : 1.0;
    // SensorTimestamp is the start of exposure on CLOCK_BOOTTIME (libcamera's definition);
    // BOOTTIME - MONOTONIC is the time spent suspended, taken now. Mid-exposure is what the
    // capture pipeline wants.
    const std::int64_t start = sensor_ts ? *sensor_ts - (clock_ns(CLOCK_BOOTTIME) - clock_ns(CLOCK_MONOTONIC))
                                         : std::int64_t(buffer->metadata().timestamp);
    f.t_ns = start + std::int64_t(f.exposure_s * 0.5e9);
    f.sequence = buffer->metadata().sequence;
    return f;
}

std::optional<CameraFrame> LibcameraSource::next_frame(std::chrono::milliseconds timeout) {
    if (!camera_ || !streaming_) return std::nullopt;
    libcamera::Request* request = nullptr;
    {
        std::unique_lock lock(mutex_);
        if (!ready_.wait_for(lock, timeout, [&] { return !completed_.empty(); })) {
            ++health_.timeouts;
            lock.unlock();
            if (std::chrono::steady_clock::now() - last_frame_ > options_.restart_after) {
                // The pipeline stalled (a request timed out in the ISP or sensor): restart it.
                health_.last_error = description_ + ": no frame for " +
                                     std::to_string(options_.restart_after.count()) + " ms, camera restarted";
                stop_streaming();
                start_streaming();
                ++health_.restarts;
            }
            return std::nullopt;
        }
        request = completed_.front();
        completed_.pop_front();
    }
    std::optional<CameraFrame> frame;
    if (request->findBuffer(stream_)->metadata().status == libcamera::FrameMetadata::FrameSuccess) {
        frame = convert(request);
        const std::lock_guard lock(mutex_);
        if (have_sequence_ && frame->sequence > last_sequence_ + 1) health_.dropped += frame->sequence - last_sequence_ - 1;
        last_sequence_ = frame->sequence;
        have_sequence_ = true;
        ++health_.frames;
        last_frame_ = std::chrono::steady_clock::now();
    } else {
        const std::lock_guard lock(mutex_);
        ++health_.dropped;
        health_.last_error = description_ + ": a frame completed with an error";
    }
    request->reuse(libcamera::Request::ReuseBuffers);
    queue(request);
    return frame;
}

void LibcameraSource::set_exposure(const ExposureRequest& request) {
    const std::lock_guard lock(mutex_);
    exposure_ = request;
}

CameraHealth LibcameraSource::health() const {
    const std::lock_guard lock(mutex_);
    return health_;
}

void LibcameraSource::stop() {
    if (camera_) {
        stop_streaming();
        camera_->requestCompleted.disconnect(this, &LibcameraSource::on_request_completed);
        requests_.clear();
        for (const Mapped& m : mapped_) munmap(m.data, m.length);
        mapped_.clear();
        allocator_.reset();
        if (acquired_) camera_->release();
        acquired_ = false;
        camera_.reset();
    }
    manager_.reset();
}

}  // namespace glint::capture
