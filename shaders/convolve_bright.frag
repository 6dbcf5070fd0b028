#version 300 es
// The bright texels' terms of one map, for every output texel:
// sum_b (cos_b / cmax)^n L_b dOmega_b (up to e^80 each) over the bright texels whose
// cosine reaches their own cut-off (the CPU sets it from the tolerance).
precision highp float;
precision highp int;
#include "equirect.glsl"

uniform highp sampler2D u_bright;    // RGBA32F, 2 x count: (direction, min cosine), (L dOmega, 0)
uniform int u_count;
uniform float u_n;
uniform highp sampler2D u_log_cmax;  // R32F, classes x output height: log of the largest cosine
uniform int u_classes;
uniform ivec2 u_out_size;

layout(location = 0) out vec4 o_bright;

void main() {
    int col = int(gl_FragCoord.x), row = int(gl_FragCoord.y);
    float tr = row_theta(row, u_out_size.y);
    float pr = column_phi(col, u_out_size.x);
    vec3 r = vec3(sin(tr) * sin(pr), cos(tr), -sin(tr) * cos(pr));
    float log_cmax = texelFetch(u_log_cmax, ivec2(col % u_classes, row), 0).r;
    vec3 sum = vec3(0.0);
    for (int b = 0; b < u_count; ++b) {
        vec4 dir = texelFetch(u_bright, ivec2(0, b), 0);
        vec3 diff = r - dir.xyz;
        float x = 0.5 * dot(diff, diff);  // 1 - cos, without cancellation
        if (1.0 - x < dir.w || x >= 1.0) continue;
        // Unclamped (a bright texel may lie nearer than cmax's texel), up to e^80 (float).
        float w = exp(min(80.0, u_n * (log1m(x) - log_cmax)));
        sum += w * texelFetch(u_bright, ivec2(1, b), 0).rgb;
    }
    o_bright = vec4(sum, 0.0);
}
