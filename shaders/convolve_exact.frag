#version 300 es
// `exact` on the GPU: every input texel for every output texel, for up to 8
// maps of one output size at once (one render target each). Weights relative
// to the largest cosine, in log space (docs/conventions.md: never 0/0).
// One draw sums the input rows [u_row_begin, u_row_end) and writes the
// unnormalised (numerator RGB, denominator); draws over bands of rows add up
// in the targets by float blending, and the CPU divides. Bands keep each
// draw's loop short: llvmpipe stops a loop after 65535 iterations, and a
// bounded draw is what the tile scheduler needs. Float accumulation in two
// levels (per input row, then rows) keeps ~1e-6 relative accuracy.
precision highp float;
precision highp int;
#include "equirect.glsl"

uniform highp sampler2D u_input;  // RGBA32F, the input map (RGB used)
uniform ivec2 u_out_size;
uniform int u_classes;            // output columns col and col + u_classes share their offsets
uniform int u_maps;               // 1 .. 8
uniform int u_row_begin;          // the band of input rows this draw sums
uniform int u_row_end;
uniform float u_n[8];             // shininess of each map (1 for irradiance)

layout(location = 0) out vec4 o_map0;
layout(location = 1) out vec4 o_map1;
layout(location = 2) out vec4 o_map2;
layout(location = 3) out vec4 o_map3;
layout(location = 4) out vec4 o_map4;
layout(location = 5) out vec4 o_map5;
layout(location = 6) out vec4 o_map6;
layout(location = 7) out vec4 o_map7;

void main() {
    ivec2 in_size = textureSize(u_input, 0);
    int col = int(gl_FragCoord.x), row = int(gl_FragCoord.y);
    float tr = row_theta(row, u_out_size.y);
    float str = sin(tr);
    // Column offsets from the texel's class (see convolve_cone.frag), so the
    // weights of a class are the same bit for bit.
    int cls = col % u_classes, q = col / u_classes;
    int step = in_size.x / (u_out_size.x / u_classes);
    float x_cls = (float(cls) + 0.5) * float(in_size.x) / float(u_out_size.x) - 0.5;
    float f = x_cls - floor(x_cls);
    int base = q * step + int(floor(x_cls));
    // The largest cosine to any input texel centre: the nearest column offset
    // on every row (as LobeSummer::cmax).
    float s_near = sin(0.5 * TWO_PI / float(in_size.x) * min(f, 1.0 - f));
    float x_min = 2.0;
    for (int j = 0; j < in_size.y; ++j) {
        float tk = row_theta(j, in_size.y);
        x_min = min(x_min, one_minus_cos(sin(0.5 * (tr - tk)), str, sin(tk), s_near));
    }
    float log_cmax = log1m(x_min);

    vec3 num[8];
    float den[8];
    for (int k = 0; k < 8; ++k) { num[k] = vec3(0.0); den[k] = 0.0; }
    float half_dphi = 0.5 * PI / float(in_size.y);
    for (int j = u_row_begin; j < u_row_end; ++j) {
        float tk = row_theta(j, in_size.y);
        float sdt = sin(0.5 * (tr - tk)), stk = sin(tk);
        // dOmega_j = (2 pi / W) (cos(pi j / H) - cos(pi (j + 1) / H)), without cancellation.
        float omega = TWO_PI / float(in_size.x) * 2.0 * sin(tk) * sin(half_dphi);
        vec3 row_num[8];
        float row_den[8];
        for (int k = 0; k < 8; ++k) { row_num[k] = vec3(0.0); row_den[k] = 0.0; }
        // Every column, as offsets d from the class's base column.
        int d0 = -(in_size.x / 2);
        for (int d = d0; d < d0 + in_size.x; ++d) {
            float xk = one_minus_cos(sdt, str, stk, sin(0.5 * TWO_PI / float(in_size.x) * (float(d) - f)));
            if (xk >= 1.0) continue;  // only texels above the horizon count, also for n = 0
            int i = base + d;
            i = i - in_size.x * int(floor(float(i) / float(in_size.x)));
            vec3 radiance = texelFetch(u_input, ivec2(i, j), 0).rgb;
            float lw = log1m(xk) - log_cmax;
            for (int k = 0; k < u_maps; ++k) {
                float w = exp(u_n[k] * lw);
                row_num[k] += w * radiance;
                row_den[k] += w;
            }
        }
        for (int k = 0; k < u_maps; ++k) {
            num[k] += omega * row_num[k];
            den[k] += omega * row_den[k];
        }
    }
    vec4 result[8];
    for (int k = 0; k < 8; ++k) result[k] = vec4(num[k], den[k]);
    o_map0 = result[0];
    o_map1 = result[1];
    o_map2 = result[2];
    o_map3 = result[3];
    o_map4 = result[4];
    o_map5 = result[5];
    o_map6 = result[6];
    o_map7 = result[7];
}
