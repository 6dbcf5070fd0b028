#include "appliance/convolution/gpu/tile_runner.hpp"

#include <GLES3/gl3.h>
#include <GLES2/gl2ext.h>

#include <algorithm>
#include <cmath>

namespace glint::convolution::gpu {
namespace {

constexpr int kMaxTileRows = 8;

// The extension's entry points, resolved once (core GLES 3.0 has no timer queries).
struct TimerQuery {
    PFNGLQUERYCOUNTEREXTPROC counter = nullptr;
    PFNGLGETQUERYOBJECTUI64VEXTPROC get_u64 = nullptr;
    bool ok = false;
};

const TimerQuery& timer_query() {
    static const TimerQuery q = [] {
        TimerQuery t;
        t.get_u64 = reinterpret_cast<PFNGLGETQUERYOBJECTUI64VEXTPROC>(eglGetProcAddress("glGetQueryObjectui64vEXT"));
        t.ok = t.get_u64 != nullptr;
        return t;
    }();
    return q;
}

}  // namespace

TileRunner::TileRunner(const gl::GlCapabilities& caps, TileGate& gate, double hard_cap_ms, TileCost& cost)
    : timer_query_(caps.timer_query && timer_query().ok), gate_(gate), hard_cap_ms_(hard_cap_ms), cost_(cost) {}

double TileRunner::measure(const TileRect& tile, const std::function<void(const TileRect&)>& draw) {
    glEnable(GL_SCISSOR_TEST);
    glScissor(tile.x, tile.y, tile.width, tile.height);
    const auto start = std::chrono::steady_clock::now();
    const auto cpu_ms = [&] {
        return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
    };
    if (timer_query_) {
        gl::GlQuery query = gl::GlQuery::create();
        glBeginQuery(GL_TIME_ELAPSED_EXT, query.id());
        draw(tile);
        glEndQuery(GL_TIME_ELAPSED_EXT);
        GLuint64 ns = 0;
        timer_query().get_u64(query.id(), GL_QUERY_RESULT, &ns);  // waits for the result
        GLint disjoint = 0;
        glGetIntegerv(GL_GPU_DISJOINT_EXT, &disjoint);
        glDisable(GL_SCISSOR_TEST);
        const double gpu = double(ns) * 1e-6, wall = cpu_ms();
        // The GPU's time lies inside the wall time we waited for it; a result
        // outside it (a disjoint event, or the first query of a context on
        // llvmpipe: 1e7 ms, measured) is not believed. And the tile is charged
        // the longer of the two: what the frame loses is the wall time the GPU
        // was busy with it (on llvmpipe the query reported a fraction of it for
        // heavy shaders, and the sized-up tiles held the render thread's frames
        // for up to 0.7 s).
        if (!disjoint && gpu <= 1.5 * wall + 1.0) return std::max(gpu, wall);
        return wall;
    }
    draw(tile);
    gl::GlFence::insert().wait();
    glDisable(GL_SCISSOR_TEST);
    return cpu_ms();
}

void TileRunner::run(int width, int height, const std::function<void(const TileRect&)>& draw,
                     const std::function<void(const TileRect&)>& on_tile, const std::vector<double>* row_work) {
    // Work of one texel of row y, in the units the cost model learns: the
    // caller's estimate (how many terms the row's texels sum), else 1.
    const auto work = [&](int y) { return row_work ? std::max(1e-3, (*row_work)[std::size_t(y)]) : 1.0; };
    int x = 0, y = 0;
    while (y < height) {
        const double limit = std::min(gate_.acquire(), hard_cap_ms_);
        TileRect tile;
        tile.x = x;
        tile.y = y;
        if (cost_.ms_per_work < 0) {
            // First tile of the program: one texel, to learn the cost (a texel
            // of an SH band on llvmpipe took ~6 ms; 16 of them broke the cap).
            tile.width = 1;
            tile.height = 1;
        } else {
            // Half the limit, and at most 4x the last tile's work: the work
            // estimate is only relative, and texels of one pass can differ in
            // cost by orders of magnitude (masked texels of an annulus pass cost
            // nothing, polar rows read more columns).
            const double budget = std::min(0.5 * limit / cost_.ms_per_work, 4.0 * cost_.last_work);
            if (x == 0 && budget >= work(y) * width) {
                double used = 0;
                int rows = 0;
                // At most kMaxTileRows rows: the per-row work is an estimate, and a
                // tile of many rows that it underrates overruns the cap (measured:
                // 35 rows predicted at 25 ms took 80 ms on studio's bright texels).
                while (y + rows < height && rows < kMaxTileRows && used + work(y + rows) * width <= budget)
                    used += work(y + rows++) * width;
                tile.width = width;
                tile.height = std::max(1, rows);
            } else {
                tile.width = int(std::clamp(std::floor(budget / work(y)), 1.0, double(width - x)));
                tile.height = 1;
            }
        }
        double tile_work = 0;
        for (int r = tile.y; r < tile.y + tile.height; ++r) tile_work += work(r) * tile.width;
        const double ms = measure(tile, draw);
        gate_.spent(ms);
        cost_.last_work = tile_work;
        const double per_work = ms / tile_work;
        // Smoothed, but a slower tile is believed at once (the cap must hold).
        cost_.ms_per_work = cost_.ms_per_work < 0 ? per_work : std::max(per_work, 0.5 * (cost_.ms_per_work + per_work));
        ++stats_.tiles;
        stats_.gpu_ms += ms;
        stats_.largest_ms = std::max(stats_.largest_ms, ms);
        if (on_tile) on_tile(tile);
        x += tile.width;
        if (x >= width) {
            x = 0;
            y += tile.height;
        }
    }
}

}  // namespace glint::convolution::gpu
