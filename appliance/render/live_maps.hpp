// The shading maps made while the frames run (docs/render.md, "Live maps"): `glint render
// --live-maps`. Coarse maps first (the CPU engine at a small size, a fraction of a second), so the
// object is lit from the first frame; the final maps (tolerance 1 %) by the GPU engine
// (appliance/convolution/gpu) on a worker thread with its own GL context, shared with the
// renderer's, whose tiles run only in each frame's leftover time (FrameBudgetGate): the render
// thread grants what the frame did not use of its budget, and the renderer switches to the final
// maps when they are done.
#pragma once

#include <atomic>
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

class LiveMaps {
public:
    // Starts the final maps' job. `main` is the render thread's context, current on the caller's
    // thread: the worker's context shares its objects. frame_budget_ms: the frame period the
    // render loop aims at (what it grants is that minus the frame's own time). Returns once the
    // worker's context is made and its programs compiled (the driver may hold a lock while it
    // compiles: at start-up, not in the middle of a frame).
    // wait_until_ready = false (the kiosk, mid-flow): returns at once; the worker makes its
    // context and programs while the frames go on (measured: no frame of the replay got slower).
    LiveMaps(const gl::GlContext& main, const HdrImage& environment, std::vector<Material> materials,
             double frame_budget_ms, bool wait_until_ready = true);
    ~LiveMaps();  // cancels the job and joins the worker
    LiveMaps(const LiveMaps&) = delete;
    LiveMaps& operator=(const LiveMaps&) = delete;

    // Render thread, after the frame: grants the job the rest of the budget (budget - frame_ms),
    // returns the slice granted (0 when the frame used the budget up or the job is done).
    double after_frame(double frame_ms);
    // Render thread: grants slices until the job is done (the files of a still frame).
    void finish();
    bool done() const { return done_.load(); }
    // The final maps, once, when done (empty before and after); rethrows the job's error.
    std::optional<ShadingMaps> take();
    double seconds() const { return seconds_; }  // the job's wall time, when done
    const convolution::gpu::TileStats& tiles() const { return tiles_; }
    double budget_ms() const { return budget_ms_; }

private:
    double budget_ms_;
    convolution::gpu::FrameBudgetGate gate_;
    gl::EglDisplay display_;  // a reference on the renderer's EGL display, for the worker's context
    std::atomic<bool> done_{false}, taken_{false}, ready_{false};
    std::optional<ShadingMaps> result_;
    std::exception_ptr error_;
    double seconds_ = 0;
    convolution::gpu::TileStats tiles_;
    std::thread worker_;
};

}  // namespace glint::render
