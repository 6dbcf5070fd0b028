#include "appliance/render/live_maps.hpp"

#include <EGL/egl.h>

#include <chrono>
#include <optional>

#include "appliance/convolution/convolution.hpp"
#include "appliance/convolution/gpu/gpu_engine.hpp"
#include "appliance/core/errors.hpp"
#include "appliance/core/parallel.hpp"

namespace glint::render {

ShadingMaps coarse_maps(const HdrImage& environment, const std::vector<Material>& materials, int threads) {
    convolution::Options o;
    o.tolerance = 0.05;
    o.size = convolution::Size{32, 16};
    o.threads = threads;
    ShadingMaps maps = convolve_maps(environment, materials, o);
    if (maps.irradiance) maps.irradiance_from = "coarse: " + maps.irradiance_from;
    for (ReflectionMap& r : maps.reflections) r.from = "coarse: " + r.from;
    return maps;
}

LiveMaps::LiveMaps(const gl::GlContext& main, double frame_budget_ms, bool wait_until_ready)
    : budget_ms_(frame_budget_ms), display_(eglGetCurrentDisplay()) {
    if (!(frame_budget_ms > 0)) throw InputError("--frame-budget-ms: must be positive");
    if (display_.handle() == EGL_NO_DISPLAY) throw RuntimeError("live maps: no EGL display is current");
    worker_ = std::thread([this, &main] { run(main); });
    while (wait_until_ready && !ready_) std::this_thread::sleep_for(std::chrono::milliseconds(1));
}

LiveMaps::LiveMaps(const gl::GlContext& main, const HdrImage& environment, std::vector<Material> materials,
                   double frame_budget_ms, bool wait_until_ready)
    : LiveMaps(main, frame_budget_ms, wait_until_ready) {
    start(environment, std::move(materials));
}

LiveMaps::~LiveMaps() {
    {
        std::lock_guard lock(mutex_);
        quit_ = true;
    }
    gate_.cancel();
    wake_.notify_all();
    if (worker_.joinable()) worker_.join();
}

void LiveMaps::run(const gl::GlContext& main) {
    // The job's CPU parts (SH projections, the cone's bounds, read-backs) and the compiles must
    // not take the cores from the frames.
    lower_this_thread_priority();
    std::exception_ptr setup_error;
    {
        std::optional<gl::GlContext> context;
        std::optional<convolution::gpu::GpuEngine> engine;
        try {
            context.emplace(display_, nullptr, &main);
            context->make_current();
            engine.emplace(*context, gate_);
            engine->prepare_programs();
        } catch (...) {
            setup_error = std::current_exception();  // every job reports it
        }
        ready_ = true;
        for (;;) {
            Job job;
            {
                std::unique_lock lock(mutex_);
                wake_.wait(lock, [&] { return quit_ || pending_.has_value(); });
                if (quit_) break;
                job = std::move(*pending_);
                pending_.reset();
                running_ = true;
            }
            const auto t0 = std::chrono::steady_clock::now();
            std::optional<ShadingMaps> maps;
            std::exception_ptr error = setup_error;
            convolution::gpu::TileStats stats;
            if (!error) {
                try {
                    engine->reset_stats();
                    convolution::Options o;
                    o.tolerance = 0.01;
                    o.threads = 1;  // the render thread keeps the other core
                    o.executor = &*engine;
                    o.fine_tiles = true;  // a sharp lobe's finer grid only where lookups need it
                    maps = convolve_maps(*job.environment, job.materials, o);
                    if (maps->irradiance) maps->irradiance_from = "live (GPU): " + maps->irradiance_from;
                    for (ReflectionMap& r : maps->reflections) r.from = "live (GPU): " + r.from;
                } catch (const convolution::gpu::JobCancelled&) {
                    maps.reset();
                } catch (...) {
                    error = std::current_exception();
                }
                stats = engine->stats();
            }
            // Done before the gate closes (a render thread granting slices then stops at once);
            // running_ false only after it closed: start() reopens it for the next job.
            {
                std::lock_guard lock(mutex_);
                result_ = std::move(maps);
                error_ = error;
                tiles_ = stats;
                seconds_ = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
                done_ = true;
            }
            gate_.finish();
            {
                std::lock_guard lock(mutex_);
                running_ = false;
            }
            wake_.notify_all();
        }
    }
    eglReleaseThread();
}

void LiveMaps::start(const HdrImage& environment, std::vector<Material> materials) {
    start(std::make_shared<const HdrImage>(environment), std::move(materials));
}

void LiveMaps::start(std::shared_ptr<const HdrImage> environment, std::vector<Material> materials) {
    if (!environment) throw InputError("live maps: no environment map");
    std::unique_lock lock(mutex_);
    if (running_) {
        gate_.cancel();
        wake_.wait(lock, [&] { return !running_; });
    }
    gate_.reset();
    done_ = false;
    taken_ = false;
    result_.reset();
    error_ = nullptr;
    pending_ = Job{std::move(environment), std::move(materials)};
    started_ = true;
    lock.unlock();
    wake_.notify_all();
}

double LiveMaps::after_frame(double frame_ms) {
    if (!started_ || done_) return 0;
    const double left = budget_ms_ - frame_ms;
    if (left <= 0) return 0;
    gate_.run_slice(left);
    return left;
}

void LiveMaps::finish() {
    while (started_ && !done_) gate_.run_slice(1000.0);
}

std::optional<ShadingMaps> LiveMaps::take() {
    if (!started_ || !done_ || taken_) return std::nullopt;
    taken_ = true;
    std::lock_guard lock(mutex_);
    if (error_) std::rethrow_exception(error_);
    return std::move(result_);
}

}  // namespace glint::render
