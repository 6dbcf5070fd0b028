#include "appliance/convolution/gpu/tile_runner.hpp"

#include <GLES3/gl3.h>
#include <GLES2/gl2ext.h>

#include <algorithm>
#include <cmath>

namespace glint::convolution::gpu {
namespace {

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

TileRunner::TileRunner(const render::GlCapabilities& caps, TileGate& gate, double hard_cap_ms)
    : timer_query_(caps.timer_query && timer_query().ok), gate_(gate), hard_cap_ms_(hard_cap_ms) {}

double TileRunner::measure(const TileRect& tile, const std::function<void(const TileRect&)>& draw) {
    glEnable(GL_SCISSOR_TEST);
    glScissor(tile.x, tile.y, tile.width, tile.height);
    const auto start = std::chrono::steady_clock::now();
    const auto cpu_ms = [&] {
        return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
    };
    if (timer_query_) {
        render::GlQuery query = render::GlQuery::create();
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
        // llvmpipe: 1e7 ms, measured) is not believed.
        if (!disjoint && gpu <= 1.5 * wall + 1.0) return gpu;
        return wall;
    }
    draw(tile);
    render::GlFence::insert().wait();
    glDisable(GL_SCISSOR_TEST);
    return cpu_ms();
}

void TileRunner::run(int width, int height, const std::function<void(const TileRect&)>& draw,
                     const std::function<void(const TileRect&)>& on_tile) {
    int x = 0, y = 0;
    while (y < height) {
        const double limit = std::min(gate_.acquire(), hard_cap_ms_);
        TileRect tile;
        tile.x = x;
        tile.y = y;
        if (ms_per_texel_ < 0) {
            // First tile of the runner: a small one, to learn the cost.
            tile.width = std::min(width - x, 16);
            tile.height = 1;
        } else {
            const double texels = std::max(1.0, std::floor(0.8 * limit / ms_per_texel_));  // 20 % headroom
            if (x == 0 && texels >= width) {
                tile.width = width;
                tile.height = int(std::min<double>(height - y, std::floor(texels / width)));
            } else {
                tile.width = int(std::min<double>(width - x, texels));
                tile.height = 1;
            }
        }
        const double ms = measure(tile, draw);
        gate_.spent(ms);
        const double per_texel = ms / double(tile.width * tile.height);
        // Smoothed, but a slower tile is believed at once (the cap must hold).
        ms_per_texel_ = ms_per_texel_ < 0 ? per_texel : std::max(per_texel, 0.5 * (ms_per_texel_ + per_texel));
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
