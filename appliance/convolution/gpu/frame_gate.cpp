#include "appliance/convolution/gpu/frame_gate.hpp"

#include <chrono>

namespace glint::convolution::gpu {

void FrameBudgetGate::run_slice(double ms) {
    std::unique_lock lock(mutex_);
    if (finished_ || ms < min_tile_ms_) return;
    allowance_ = ms;
    slice_open_ = true;
    job_wake_.notify_all();
    // Until the job has spent the slice and asks for more, or ends, or the
    // slice's time is over (the job may be doing CPU work between passes:
    // that does not hold up the frame; its next tile waits for the next slice).
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double, std::milli>(ms);
    render_wake_.wait_until(lock, deadline,
                            [&] { return finished_ || (job_waiting_ && allowance_ < min_tile_ms_); });
    slice_open_ = false;
    allowance_ = 0;
}

void FrameBudgetGate::cancel() {
    std::lock_guard lock(mutex_);
    cancelled_ = true;
    job_wake_.notify_all();
}

void FrameBudgetGate::finish() {
    std::lock_guard lock(mutex_);
    finished_ = true;
    render_wake_.notify_all();
}

void FrameBudgetGate::reset() {
    std::lock_guard lock(mutex_);
    allowance_ = 0;
    slice_open_ = false;
    job_waiting_ = false;
    cancelled_ = false;
    finished_ = false;
}

double FrameBudgetGate::acquire() {
    std::unique_lock lock(mutex_);
    job_waiting_ = true;
    render_wake_.notify_all();  // the slice may be spent: let the render thread go on
    job_wake_.wait(lock, [&] { return cancelled_ || (slice_open_ && allowance_ >= min_tile_ms_); });
    job_waiting_ = false;
    if (cancelled_) throw JobCancelled();
    return allowance_;
}

void FrameBudgetGate::spent(double ms) {
    std::lock_guard lock(mutex_);
    allowance_ -= ms;
}

}  // namespace glint::convolution::gpu
