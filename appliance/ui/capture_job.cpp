#include "appliance/ui/capture_job.hpp"

#include <algorithm>

namespace glint::ui {

std::optional<capture::CameraFrame> FeedCamera::next_frame(std::chrono::milliseconds timeout) {
    std::unique_lock lock(mutex_);
    if (!ready_.wait_for(lock, timeout, [&] { return !queue_.empty() || closed_; })) return std::nullopt;
    if (queue_.empty()) return std::nullopt;  // closed: finished() says so
    capture::CameraFrame f = std::move(queue_.front());
    queue_.pop_front();
    ++delivered_;
    return f;
}

bool FeedCamera::finished() const {
    std::lock_guard lock(mutex_);
    return closed_ && queue_.empty();
}

capture::CameraHealth FeedCamera::health() const {
    std::lock_guard lock(mutex_);
    capture::CameraHealth h;
    h.frames = delivered_;
    return h;
}

void FeedCamera::push(capture::CameraFrame frame) {
    {
        std::lock_guard lock(mutex_);
        queue_.push_back(std::move(frame));
    }
    ready_.notify_one();
}

void FeedCamera::close() {
    {
        std::lock_guard lock(mutex_);
        closed_ = true;
    }
    ready_.notify_all();
}

namespace {
// The sample counts of the live map boiled down to the minimap's cells: the mean count over each
// cell's texels, 4 or more frames drawn as full.
std::vector<std::uint8_t> minimap_of(const std::vector<std::uint32_t>& samples, int width, int height, int mw, int mh) {
    std::vector<std::uint8_t> cells(std::size_t(mw) * mh, 0);
    if (width <= 0 || height <= 0 || samples.size() != std::size_t(width) * height) return cells;
    for (int cy = 0; cy < mh; ++cy)
        for (int cx = 0; cx < mw; ++cx) {
            const int x0 = cx * width / mw, x1 = (cx + 1) * width / mw, y0 = cy * height / mh, y1 = (cy + 1) * height / mh;
            double sum = 0;
            for (int y = y0; y < y1; ++y)
                for (int x = x0; x < x1; ++x) sum += std::min<std::uint32_t>(samples[std::size_t(y) * width + x], 4);
            const double mean = sum / std::max(1, (x1 - x0) * (y1 - y0));
            cells[std::size_t(cy) * mw + cx] = std::uint8_t(std::lround(255.0 * mean / 4.0));
        }
    return cells;
}
}  // namespace

namespace {
struct CaptureCancelled {};  // thrown through the pipeline from its progress callback
}  // namespace

CaptureJob::CaptureJob(capture::CaptureOptions options) : options_(std::move(options)) {
    options_.on_frame = [this](const capture::GuidedStep& step, const glm::dquat& q, const std::vector<std::uint32_t>& samples) {
        CaptureLiveStatus s;
        s.step = step;
        s.world_from_camera = q;
        s.has_step = true;
        s.minimap = minimap_of(samples, options_.width, options_.height, s.minimap_width, s.minimap_height);
        std::lock_guard lock(mutex_);
        live_ = std::move(s);
    };
    worker_ = std::thread([this] {
        try {
            capture::CaptureSummary s =
                capture::run_capture(options_, feed_, nullptr, [this](long long d, long long t) { on_progress(d, t); });
            std::lock_guard lock(mutex_);
            summary_ = std::move(s);
        } catch (const CaptureCancelled&) {
            // Nobody waits for this map any more.
        } catch (...) {
            std::lock_guard lock(mutex_);
            error_ = std::current_exception();
        }
        {
            std::lock_guard lock(mutex_);
            finishing_seconds_ = std::chrono::duration<double>(std::chrono::steady_clock::now() - finish_at_).count();
        }
        done_ = true;
        progressed_.notify_all();
    });
}

CaptureJob::~CaptureJob() {
    cancelled_ = true;
    feed_.close();
    if (worker_.joinable()) worker_.join();
}

void CaptureJob::on_progress(long long done, long long) {
    if (cancelled_) throw CaptureCancelled{};
    progress_ = done;
    progressed_.notify_all();
}

void CaptureJob::push(const capture::CameraFrame& frame) {
    feed_.push({frame.rgb.clone(), frame.t_ns, frame.exposure_s, frame.analogue_gain, frame.digital_gain, frame.sequence});
    ++pushed_;
}

void CaptureJob::finish() {
    {
        std::lock_guard lock(mutex_);
        finish_at_ = std::chrono::steady_clock::now();
        progress_at_finish_ = progress_.load();
        used_at_finish_ = pushed_;
    }
    feed_.close();
}

void CaptureJob::wait_for_frames() {
    std::unique_lock lock(mutex_);
    // The live pass reports one step of progress per frame it took in (used or not).
    progressed_.wait(lock, [&] { return progress_.load() >= (long long)pushed_ || done_.load(); });
}

CaptureLiveStatus CaptureJob::live() const {
    std::lock_guard lock(mutex_);
    return live_;
}

double CaptureJob::finishing_progress() const {
    if (done_) return 1;
    std::lock_guard lock(mutex_);
    if (progress_at_finish_ < 0) return 0;
    // After the last frame the pipeline counts one step per frame of the final map.
    const double steps = double(progress_.load() - std::max<long long>(progress_at_finish_, (long long)used_at_finish_));
    return std::clamp(steps / std::max<double>(1, double(used_at_finish_)), 0.0, 0.99);
}

std::optional<capture::CaptureSummary> CaptureJob::take() {
    if (!done_) return std::nullopt;
    std::lock_guard lock(mutex_);
    if (error_) std::rethrow_exception(error_);
    if (taken_) return std::nullopt;
    taken_ = true;
    return std::move(summary_);
}

}  // namespace glint::ui
