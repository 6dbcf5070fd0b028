#version 300 es
// SH reconstruction on the GPU (sh_evaluate): E(theta, phi) =
//   sum_m H_m cos(m phi) + K_m sin(m phi),
//   H_m = sum_{l >= m} w_lm \bar P_lm(cos theta),  K_m likewise with the c_l,-m,
// where w_lm = kernel_l s_m c_lm (s_0 = 1, s_m = sqrt 2), packed by column m
// (index m * order - m (m - 1) / 2 + l - m) in 4096-wide textures, with the
// recurrence of each column (\bar P_lm = a (x \bar P_l-1,m - b \bar P_l-2,m))
// and \bar P_mm per output row from the CPU. One draw sums the columns
// [u_m_begin, u_m_end) and the draws add up by float blending (bands keep
// each loop under llvmpipe's 65535 iterations).
precision highp float;
precision highp int;
#include "equirect.glsl"

uniform highp sampler2D u_cos_weights;  // RGB: w_lm for c_lm
uniform highp sampler2D u_sin_weights;  // RGB: w_lm for c_l,-m
uniform highp sampler2D u_steps;        // RG: a, b of the recurrence
uniform highp sampler2D u_pmm;          // R: \bar P_mm, order x output height
uniform int u_order;
uniform int u_m_begin;
uniform int u_m_end;
uniform ivec2 u_out_size;

layout(location = 0) out vec4 o_value;

ivec2 at(int index) { return ivec2(index % 4096, index / 4096); }

void main() {
    int col = int(gl_FragCoord.x), row = int(gl_FragCoord.y);
    float x = cos(row_theta(row, u_out_size.y));
    int two_w = 2 * u_out_size.x;
    vec3 e = vec3(0.0);
    for (int m = u_m_begin; m < u_m_end; ++m) {
        float pmm = texelFetch(u_pmm, ivec2(m, row), 0).r;
        if (pmm == 0.0) continue;  // underflowed near the poles: the whole column is negligible
        int first = m * u_order - m * (m - 1) / 2;
        float p1 = pmm, p2 = 0.0;
        vec3 h = texelFetch(u_cos_weights, at(first), 0).rgb * p1;
        vec3 k = texelFetch(u_sin_weights, at(first), 0).rgb * p1;
        for (int t = 1; t < u_order - m; ++t) {
            vec2 ab = texelFetch(u_steps, at(first + t), 0).rg;
            float p = ab.x * (x * p1 - ab.y * p2);
            h += texelFetch(u_cos_weights, at(first + t), 0).rgb * p;
            k += texelFetch(u_sin_weights, at(first + t), 0).rgb * p;
            p2 = p1;
            p1 = p;
        }
        // m phi = pi m (2 col + 1) / W - m pi, reduced in integers first.
        int r = (m * (2 * col + 1)) % two_w;
        float angle = PI * float(r) / float(u_out_size.x) - ((m & 1) == 1 ? PI : 0.0);
        e += h * cos(angle) + k * sin(angle);
    }
    o_value = vec4(e, 0.0);
}
