#version 300 es
// The thesis' MIP-map approximation (section 4.2), as mipmap_convolve on the
// CPU: a bilinear lookup in pyramid levels k0 and k1 (wrapping in azimuth,
// clamped at the poles), blended by t. Up to 8 maps per draw.
precision highp float;
precision highp int;
#include "equirect.glsl"

uniform highp sampler2D u_fine[8];
uniform highp sampler2D u_coarse[8];
uniform float u_blend[8];  // t of each map; 0: the fine level only
uniform int u_maps;
uniform ivec2 u_out_size;

layout(location = 0) out vec4 o_map0;
layout(location = 1) out vec4 o_map1;
layout(location = 2) out vec4 o_map2;
layout(location = 3) out vec4 o_map3;
layout(location = 4) out vec4 o_map4;
layout(location = 5) out vec4 o_map5;
layout(location = 6) out vec4 o_map6;
layout(location = 7) out vec4 o_map7;

vec3 bilinear(highp sampler2D image, float theta, float phi) {
    ivec2 size = textureSize(image, 0);
    float x = (phi + PI) / TWO_PI * float(size.x) - 0.5;
    float y = clamp(theta / PI * float(size.y) - 0.5, 0.0, float(size.y - 1));
    float fx0 = floor(x), fy0 = floor(y);
    float ax = x - fx0, ay = y - fy0;
    int x0 = int(fx0) - size.x * int(floor(fx0 / float(size.x)));
    int x1 = x0 + 1 == size.x ? 0 : x0 + 1;
    int y0 = int(fy0);
    int y1 = min(y0 + 1, size.y - 1);
    vec3 top = (1.0 - ax) * texelFetch(image, ivec2(x0, y0), 0).rgb + ax * texelFetch(image, ivec2(x1, y0), 0).rgb;
    vec3 bottom = (1.0 - ax) * texelFetch(image, ivec2(x0, y1), 0).rgb + ax * texelFetch(image, ivec2(x1, y1), 0).rgb;
    return (1.0 - ay) * top + ay * bottom;
}

vec4 map_value(int k, float theta, float phi) {
    vec3 a;
    vec3 b;
    // Sampler arrays take constant indices in GLSL ES 3.0.
    if (k == 0) { a = bilinear(u_fine[0], theta, phi); b = bilinear(u_coarse[0], theta, phi); }
    else if (k == 1) { a = bilinear(u_fine[1], theta, phi); b = bilinear(u_coarse[1], theta, phi); }
    else if (k == 2) { a = bilinear(u_fine[2], theta, phi); b = bilinear(u_coarse[2], theta, phi); }
    else if (k == 3) { a = bilinear(u_fine[3], theta, phi); b = bilinear(u_coarse[3], theta, phi); }
    else if (k == 4) { a = bilinear(u_fine[4], theta, phi); b = bilinear(u_coarse[4], theta, phi); }
    else if (k == 5) { a = bilinear(u_fine[5], theta, phi); b = bilinear(u_coarse[5], theta, phi); }
    else if (k == 6) { a = bilinear(u_fine[6], theta, phi); b = bilinear(u_coarse[6], theta, phi); }
    else { a = bilinear(u_fine[7], theta, phi); b = bilinear(u_coarse[7], theta, phi); }
    float t = u_blend[k];
    return vec4(t > 0.0 ? (1.0 - t) * a + t * b : a, 1.0);
}

void main() {
    int col = int(gl_FragCoord.x), row = int(gl_FragCoord.y);
    float theta = row_theta(row, u_out_size.y);
    float phi = column_phi(col, u_out_size.x);
    o_map0 = map_value(0, theta, phi);
    o_map1 = u_maps > 1 ? map_value(1, theta, phi) : vec4(0.0);
    o_map2 = u_maps > 2 ? map_value(2, theta, phi) : vec4(0.0);
    o_map3 = u_maps > 3 ? map_value(3, theta, phi) : vec4(0.0);
    o_map4 = u_maps > 4 ? map_value(4, theta, phi) : vec4(0.0);
    o_map5 = u_maps > 5 ? map_value(5, theta, phi) : vec4(0.0);
    o_map6 = u_maps > 6 ? map_value(6, theta, phi) : vec4(0.0);
    o_map7 = u_maps > 7 ? map_value(7, theta, phi) : vec4(0.0);
}
