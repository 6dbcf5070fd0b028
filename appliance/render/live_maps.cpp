#include "appliance/render/live_maps.hpp"

#include <EGL/egl.h>

#include <chrono>

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

LiveMaps::LiveMaps(const gl::GlContext& main, const HdrImage& environment, std::vector<Material> materials,
                   double frame_budget_ms, bool wait_until_ready)
    : budget_ms_(frame_budget_ms), display_(eglGetCurrentDisplay()) {
    if (!(frame_budget_ms > 0)) throw InputError("--frame-budget-ms: must be positive");
    if (display_.handle() == EGL_NO_DISPLAY) throw RuntimeError("live maps: no EGL display is current");
    worker_ = std::thread([this, &main, environment, materials = std::move(materials)] {
        const auto t0 = std::chrono::steady_clock::now();
        // The job's CPU parts (SH projections, the cone's bounds, read-backs) must not take the
        // cores from the frames.
        lower_this_thread_priority();
        try {
            gl::GlContext context(display_, nullptr, &main);
            context.make_current();
            convolution::gpu::GpuEngine engine(context, gate_);
            engine.prepare_programs();
            ready_ = true;
            convolution::Options o;
            o.tolerance = 0.01;
            o.threads = 1;  // the render thread keeps the other core
            o.executor = &engine;
            ShadingMaps maps = convolve_maps(environment, materials, o);
            if (maps.irradiance) maps.irradiance_from = "live (GPU): " + maps.irradiance_from;
            for (ReflectionMap& r : maps.reflections) r.from = "live (GPU): " + r.from;
            result_ = std::move(maps);
            tiles_ = engine.stats();
        } catch (const convolution::gpu::JobCancelled&) {
        } catch (...) {
            error_ = std::current_exception();
        }
        seconds_ = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
        eglReleaseThread();
        done_ = true;
        ready_ = true;
        gate_.finish();
    });
    while (wait_until_ready && !ready_) std::this_thread::sleep_for(std::chrono::milliseconds(1));
}

LiveMaps::~LiveMaps() {
    gate_.cancel();
    if (worker_.joinable()) worker_.join();
}

double LiveMaps::after_frame(double frame_ms) {
    if (done_) return 0;
    const double left = budget_ms_ - frame_ms;
    if (left <= 0) return 0;
    gate_.run_slice(left);
    return left;
}

void LiveMaps::finish() {
    while (!done_) gate_.run_slice(1000.0);
}

std::optional<ShadingMaps> LiveMaps::take() {
    if (!done_ || taken_) return std::nullopt;
    taken_ = true;
    if (error_) std::rethrow_exception(error_);
    return std::move(result_);
}

}  // namespace glint::render
