#include "appliance/capture/camera_pump.hpp"

namespace glint::capture {

CameraPump::CameraPump(std::unique_ptr<CameraSource> source, std::size_t max_queued)
    : source_(std::move(source)), max_queued_(std::max<std::size_t>(1, max_queued)) {}

CameraPump::~CameraPump() { stop(); }

void CameraPump::start() {
    stop();
    source_->start();
    {
        const std::lock_guard lock(mutex_);
        running_ = true;
        source_finished_ = false;
        queue_.clear();
        health_ = source_->health();
    }
    thread_ = std::thread([this] { run(); });
}

void CameraPump::stop() {
    {
        const std::lock_guard lock(mutex_);
        running_ = false;
    }
    ready_.notify_all();
    if (thread_.joinable()) thread_.join();
    source_->stop();
}

void CameraPump::run() {
    for (;;) {
        std::optional<ExposureRequest> exposure;
        {
            const std::lock_guard lock(mutex_);
            if (!running_) return;
            exposure.swap(pending_exposure_);
        }
        if (exposure) source_->set_exposure(*exposure);
        // A short wait, so that stop() is never kept waiting for long by a silent camera.
        std::optional<CameraFrame> frame = source_->next_frame(std::chrono::milliseconds(50));
        const CameraHealth health = source_->health();
        const bool finished = !frame && source_->finished();
        {
            const std::lock_guard lock(mutex_);
            health_ = health;
            if (frame) {
                if (queue_.size() >= max_queued_) {
                    queue_.pop_front();
                    ++dropped_;
                }
                queue_.push_back(std::move(*frame));
            }
            if (finished) {
                source_finished_ = true;
                running_ = false;
            }
        }
        if (frame || finished) ready_.notify_all();
        if (finished) return;
    }
}

std::optional<CameraFrame> CameraPump::next_frame(std::chrono::milliseconds timeout) {
    std::unique_lock lock(mutex_);
    ready_.wait_for(lock, timeout, [&] { return !queue_.empty() || !running_; });
    if (queue_.empty()) return std::nullopt;
    CameraFrame f = std::move(queue_.front());
    queue_.pop_front();
    return f;
}

void CameraPump::set_exposure(const ExposureRequest& request) {
    const std::lock_guard lock(mutex_);
    pending_exposure_ = request;  // the newest wins: the camera applies only the last anyway
}

bool CameraPump::finished() const {
    const std::lock_guard lock(mutex_);
    return source_finished_ && queue_.empty();
}

CameraHealth CameraPump::health() const {
    const std::lock_guard lock(mutex_);
    CameraHealth h = health_;
    h.dropped += dropped_;
    return h;
}

}  // namespace glint::capture
