// The shading maps made while the frames run (docs/render.md, "Live maps"): `glint render
// --live-maps`. Coarse maps first (the CPU engine at a small size, a fraction of a second), so the
// object is lit from the first frame; the final maps (tolerance 1 %) by the GPU engine
// (appliance/convolution/gpu) on a worker thread with its own GL context, shared with the
// renderer's, whose tiles run only in each frame's leftover time (FrameBudgetGate): the render
// thread grants what the frame did not use of its budget, and the renderer switches to the final
// maps when they are done.
#pragma once

#include <atomic>
#include <condition_variable>
#include <exception>
#include <memory>
#include <mutex>
#include <optional>
#include <thread>
#include <vector>

#include "appliance/convolution/gpu/frame_gate.hpp"
#include "appliance/core/hdr_image.hpp"
#include "appliance/gl/gl_context.hpp"
#include "appliance/render/maps.hpp"
#include "appliance/render/material.hpp"

namespace glint::render {

// The coarse maps: every lobe at 32x16 with the CPU engine (auto, tolerance 5 %): a rough but
// fair light (a 32-wide irradiance map is within a few per cent; glossy lobes are blurred).
ShadingMaps coarse_maps(const HdrImage& environment, const std::vector<Material>& materials, int threads = 0);

// A worker thread with its own GL context (sharing the render thread's objects) and the GPU
// engine's programs, made once and kept: each job (an environment and its materials) runs on it
// in the slices the render thread grants. The kiosk makes it at start-up, so that a visitor's
// frame never waits for a context to be made or a program to be compiled: llvmpipe compiles
// under a lock the render thread's draws need, and the worker's low priority then stalled the
// frame in which the maps arrived (the kiosk's PROCESSING frame of 92-108 ms).
class LiveMaps {
public:
    // Starts the worker. `main` is the render thread's context, current on the caller's thread:
    // the worker's context shares its objects. frame_budget_ms: the frame period the render loop
    // aims at (what it grants is that minus the frame's own time). wait_until_ready: returns
    // once the worker's context is made and its programs compiled (else at once; a job started
    // before then waits for them).
    LiveMaps(const gl::GlContext& main, double frame_budget_ms, bool wait_until_ready = true);
    // A worker with its first job started (glint render --live-maps).
    LiveMaps(const gl::GlContext& main, const HdrImage& environment, std::vector<Material> materials,
             double frame_budget_ms, bool wait_until_ready = true);
    ~LiveMaps();  // cancels the job and joins the worker
    LiveMaps(const LiveMaps&) = delete;
    LiveMaps& operator=(const LiveMaps&) = delete;

    // Render thread: starts the final maps (tolerance 1 %) of `environment`. A job still running
    // is cancelled first (this waits for its next tile); its maps are dropped.
    void start(const HdrImage& environment, std::vector<Material> materials);
    // The same without a copy of the map (the kiosk shares its room with the shadow's job).
    void start(std::shared_ptr<const HdrImage> environment, std::vector<Material> materials);
    // The worker's context and programs are made (or failed: the next job's take() says why).
    bool ready() const { return ready_.load(); }

    // Render thread, after the frame: grants the job the rest of the budget (budget - frame_ms),
    // returns the slice granted (0 when the frame used the budget up, or no job is running).
    double after_frame(double frame_ms);
    // Render thread: grants slices until the job is done (the files of a still frame).
    void finish();
    // The job last started is done (false before the first job).
    bool done() const { return done_.load(); }
    // The final maps, once, when done (empty before and after); rethrows the job's error.
    std::optional<ShadingMaps> take();
    double seconds() const { return seconds_; }  // the last job's wall time from its start, when done
    const convolution::gpu::TileStats& tiles() const { return tiles_; }  // the last job's tiles
    double budget_ms() const { return budget_ms_; }

private:
    struct Job {
        std::shared_ptr<const HdrImage> environment;
        std::vector<Material> materials;
    };
    void run(const gl::GlContext& main);  // the worker thread

    double budget_ms_;
    convolution::gpu::FrameBudgetGate gate_;
    gl::EglDisplay display_;  // a reference on the renderer's EGL display, for the worker's context
    std::atomic<bool> done_{false}, ready_{false};
    bool started_ = false, taken_ = false;  // render thread only
    // Shared with the worker, under mutex_: the next job, the end of the worker, the last job's
    // outcome (written before done_ is set).
    std::mutex mutex_;
    std::condition_variable wake_;
    std::optional<Job> pending_;
    bool running_ = false, quit_ = false;
    std::optional<ShadingMaps> result_;
    std::exception_ptr error_;
    double seconds_ = 0;
    convolution::gpu::TileStats tiles_;
    std::thread worker_;
};

}  // namespace glint::render
