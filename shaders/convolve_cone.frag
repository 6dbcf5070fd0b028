#version 300 es
// `cone` on the GPU: the lobe sums of one map inside a cut-off cone (first
// pass), or in the annulus between two cones for the texels the bound widened
// (second pass). Terms are chosen by x = 1 - cos: x_inner < x <= x_outer(row).
// Rows near the poles read merged columns (docs/convolution.md): the level and
// its merged versions sit side by side in one atlas, row j of version m at
// x offset u_merge_offset[log2 m]. One draw sums the level rows
// [u_row_begin, u_row_end) and writes the unnormalised (numerator RGB,
// denominator); bands add up by float blending (see convolve_exact.frag).
// The weights are relative to the largest cosine of the texel's row and
// class, which the CPU computes (LobeSummer::cmax) and passes in u_log_cmax;
// the CPU finishes the map (bright texels, bound, normalisation).
precision highp float;
precision highp int;
#include "equirect.glsl"

uniform highp sampler2D u_atlas;       // RGBA32F: the level and its merged versions
uniform highp isampler2D u_row_merge;  // R32I, level height x 1: merge factor m of each row
uniform ivec2 u_level_size;            // width and height of the level (unmerged)
uniform int u_merge_offset[8];         // atlas x offset of the version with m = 2^k
uniform ivec2 u_out_size;
uniform int u_classes;                 // output columns col and col + u_classes share their offsets
uniform float u_n;
uniform highp sampler2D u_row_x_outer; // R32F, output height x 1: x_outer of each output row
uniform float u_x_inner;               // terms with x <= x_inner are left out (-1: none)
uniform bool u_use_mask;
uniform highp sampler2D u_mask;        // R32F, output size: texels to compute (> 0.5)
uniform highp sampler2D u_log_cmax;    // R32F, classes x output height: log of the largest cosine
uniform int u_row_begin;               // the band of level rows this draw sums
uniform int u_row_end;

layout(location = 0) out vec4 o_sums;

int log2i(int m) { int k = 0; while ((1 << k) < m) ++k; return k; }

void main() {
    int col = int(gl_FragCoord.x), row = int(gl_FragCoord.y);
    if (u_use_mask && texelFetch(u_mask, ivec2(col, row), 0).r < 0.5) {
        o_sums = vec4(0.0);
        return;
    }
    int W = u_level_size.x, H = u_level_size.y;
    float tr = row_theta(row, u_out_size.y);
    float str = sin(tr);

    // Column offsets from this texel's class, so that every texel of a class
    // computes the same weights bit for bit (the CPU keeps one denominator per
    // row and class): the centre of column col is at q * step + x_cls.
    int cls = col % u_classes, q = col / u_classes;
    int per_class = u_out_size.x / u_classes;

    float log_cmax = texelFetch(u_log_cmax, ivec2(cls, row), 0).r;

    float x_outer = texelFetch(u_row_x_outer, ivec2(row, 0), 0).r;
    // Rows within reach: 2 sin^2(dt / 2) <= x_outer.
    float reach = 2.0 * asin(min(1.0, sqrt(0.5 * x_outer)));
    int j0 = max(u_row_begin, int(floor((tr - reach) / PI * float(H) - 0.5)) - 1);
    int j1 = min(u_row_end - 1, int(ceil((tr + reach) / PI * float(H) - 0.5)) + 1);
    float half_dt = 0.5 * PI / float(H);
    vec3 num = vec3(0.0);
    float den = 0.0;
    for (int j = j0; j <= j1; ++j) {
        int m = texelFetch(u_row_merge, ivec2(j, 0), 0).r;
        int wm = W / m;
        int offset = u_merge_offset[log2i(m)];
        float tk = row_theta(j, H);
        float sdt = sin(0.5 * (tr - tk)), stk = sin(tk);
        float rest = x_outer - 2.0 * sdt * sdt;
        if (rest < 0.0) continue;
        // Columns: 2 str stk sin^2(dp / 2) <= rest; one column of margin, the test below decides.
        float s = str * stk;
        float half_cols = s > 1e-30 ? 2.0 * asin(min(1.0, sqrt(rest / (2.0 * s)))) * float(wm) / TWO_PI
                                    : float(wm);
        float x_cls = (float(cls) + 0.5) * float(wm) / float(u_out_size.x) - 0.5;
        float f = x_cls - floor(x_cls);
        int base = q * (wm / per_class) + int(floor(x_cls));
        int d0 = int(ceil(f - half_cols)) - 1;
        int d1 = int(floor(f + half_cols)) + 1;
        if (d1 - d0 + 1 > wm) { d0 = int(ceil(f - 0.5 * float(wm))); d1 = d0 + wm - 1; }
        float omega = TWO_PI / float(wm) * 2.0 * stk * sin(half_dt);
        vec3 row_num = vec3(0.0);
        float row_den = 0.0;
        for (int d = d0; d <= d1; ++d) {
            int c = base + d;
            c = c - wm * int(floor(float(c) / float(wm)));
            float xk = one_minus_cos(sdt, str, stk, sin(0.5 * TWO_PI / float(wm) * (float(d) - f)));
            if (xk > x_outer || xk <= u_x_inner || xk >= 1.0) continue;
            float w = exp(u_n * (log1m(xk) - log_cmax));
            row_num += w * texelFetch(u_atlas, ivec2(offset + c, j), 0).rgb;
            row_den += w;
        }
        num += omega * row_num;
        den += omega * row_den;
    }
    o_sums = vec4(num, den);
}
