// Draws a pass over an output map in tiles sized from measured time, so that
// no single draw exceeds a hard cap and a frame scheduler can fit tiles into
// what remains of each frame's budget (docs/gpu.md).
#pragma once

#include <chrono>
#include <functional>
#include <stdexcept>
#include <vector>

#include "appliance/gl/gl_context.hpp"
#include "appliance/gl/gl_objects.hpp"

namespace glint::convolution::gpu {

// Thrown out of TileGate::acquire when the job was cancelled (a new capture
// arrived): the job unwinds and its RAII GL objects are released.
struct JobCancelled : std::runtime_error {
    JobCancelled() : std::runtime_error("convolution job cancelled") {}
};

// Who decides when the next tile may run and how long it may take.
class TileGate {
public:
    virtual ~TileGate() = default;
    // Blocks until a tile may run; returns the GPU time it may take, in ms
    // (> 0). Throws JobCancelled.
    virtual double acquire() = 0;
    // Reports the GPU time the tile took, in ms.
    virtual void spent(double ms) = 0;
};

// A gate that never waits: every tile may take up to the hard cap (the
// `glint convolve --engine gpu` command, tests).
class UnlimitedGate final : public TileGate {
public:
    explicit UnlimitedGate(double cap_ms) : cap_ms_(cap_ms) {}
    double acquire() override { return cap_ms_; }
    void spent(double) override {}

private:
    double cap_ms_;
};

struct TileRect {
    int x = 0, y = 0, width = 0, height = 0;
};

// What a TileRunner learns of a program's cost: ms per unit of work (the
// units its passes give per row) and the work of its last tile. Kept by the
// engine per program, so the bands and maps that run it do not each start
// from a one-texel probe again.
struct TileCost {
    double ms_per_work = -1;  // unknown until the first tile
    double last_work = 1;
};

struct TileStats {
    long long tiles = 0;
    double gpu_ms = 0;        // measured time of all tiles
    double largest_ms = 0;    // the longest single draw
};

// Runs draw(tile) over every texel of a width x height target in tiles: whole
// rows while a row fits the allowance, else pieces of a row. The cost per
// texel is measured (GL timer queries where GL_EXT_disjoint_timer_query
// exists, else the CPU time around a fence) and smoothed, and each tile is
// sized so its predicted time stays within min(allowance, hard cap).
class TileRunner {
public:
    TileRunner(const gl::GlCapabilities& caps, TileGate& gate, double hard_cap_ms, TileCost& cost);
    // draw: sets the scissor to the tile and issues the draw. on_tile: called
    // after each finished tile (e.g. to show progress).
    // row_work: the relative work of one texel of each row (e.g. the number
    // of terms it sums), which the cost model scales; null: uniform.
    void run(int width, int height, const std::function<void(const TileRect&)>& draw,
             const std::function<void(const TileRect&)>& on_tile = {}, const std::vector<double>* row_work = nullptr);
    const TileStats& stats() const { return stats_; }

private:
    double measure(const TileRect& tile, const std::function<void(const TileRect&)>& draw);
    bool timer_query_;
    TileGate& gate_;
    double hard_cap_ms_;
    TileCost& cost_;
    TileStats stats_;
};

}  // namespace glint::convolution::gpu
