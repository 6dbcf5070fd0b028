// The frame scheduler's side of a GPU convolution job that runs on its own
// thread and GL context (shared with the renderer's): each frame the render
// loop draws its own frame, measures it, and grants the job what remains of
// the frame's budget; the job's tiles (TileRunner) take that allowance and
// then wait for the next frame. The GPU is used by one side at a time, so the
// frame's time is its own rendering plus the tiles granted to it.
#pragma once

#include <condition_variable>
#include <mutex>

#include "appliance/convolution/gpu/tile_runner.hpp"

namespace glint::convolution::gpu {

class FrameBudgetGate final : public TileGate {
public:
    // min_tile_ms: the least allowance worth starting a tile for (a frame with
    // less left grants nothing).
    explicit FrameBudgetGate(double min_tile_ms = 0.5) : min_tile_ms_(min_tile_ms) {}

    // Render thread: lets the job use up to `ms` of GPU time now, and blocks
    // until it has used it and waits for more, or finished, or `ms` passed.
    void run_slice(double ms);
    // Render thread: ends the job at its next tile (JobCancelled in the job).
    void cancel();
    // Job thread, when it returns or throws: releases a waiting render thread.
    void finish();
    // Render thread, between two jobs (the job thread is not in the gate): opens the gate for
    // the next job of a long-lived worker (render/live_maps.hpp).
    void reset();

    // TileGate (job thread).
    double acquire() override;
    void spent(double ms) override;

private:
    std::mutex mutex_;
    std::condition_variable job_wake_, render_wake_;
    double min_tile_ms_;
    double allowance_ = 0;      // ms the job may still use in this frame's slice
    bool slice_open_ = false;   // the render thread is waiting for this slice
    bool job_waiting_ = false;  // the job is blocked in acquire()
    bool cancelled_ = false;
    bool finished_ = false;
};

}  // namespace glint::convolution::gpu
