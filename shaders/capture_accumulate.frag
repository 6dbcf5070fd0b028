#version 300 es
// HDR accumulation of one camera frame onto the sphere (appliance/capture/gpu_accumulator.hpp):
// the GPU twin of HdrAccumulator::add_frame. Every fragment is one texel of the equirect map;
// its direction is rotated into the camera, projected through the OpenCV distortion, and the
// frame's planes (X = sum w X / sum w, W = mean w, box filtered by s) are read bilinearly there
// (texelFetch: the same four texels and weights as the CPU, no filtering extension needed).
// Outputs are added by blending into the frame's exposure band (exposure_bands.hpp):
// num += (t W X, t W mean), den += (W t^2, clipped ? 1 : 0), aux += (W mean, sampled ? 1 : 0).
// A read whose four cells hold an invalid one (X's alpha > 0: a clipped pixel) adds no sample
// and counts one clipped read, as on the CPU. A rolling shutter (u_omega non-zero) reads each texel at the row whose view
// sees it, as HdrAccumulator's rolling_shutter_project: twice, the direction turned by
// -omega x the row's time offset, then projected again.
precision highp float;
precision highp int;
#include "equirect.glsl"

uniform highp sampler2D u_p;      // X_r X_g X_b, invalid (RGBA32F, pw x ph)
uniform highp sampler2D u_w;      // W_r W_g W_b, footprint zone (1: read the texel's footprint)
uniform vec4 u_camera_from_world; // quaternion (x, y, z, w)
uniform vec4 u_focal_centre;      // fx, fy, cx, cy (pixels)
uniform vec4 u_k1k2p1p2;
uniform float u_k3;
uniform vec2 u_image_size;        // pixels
uniform int u_s;                  // box filter factor
uniform float u_t;                // exposure x gain x sensitivity
uniform float u_min_weight;
uniform ivec2 u_map_size;         // W, H
uniform float u_limit_x, u_limit_y;  // normalised-coordinate bound before distorting
uniform vec3 u_omega;             // the camera's angular velocity, camera frame, rad/s
uniform float u_row_s;            // readout time per row, s
uniform float u_mid_row;          // the row whose time is the frame's: (height - 1) / 2
uniform int u_taps;               // footprint taps per side in the zone (0: point reads only)

layout(location = 0) out vec4 o_num;
layout(location = 1) out vec4 o_den;
layout(location = 2) out vec4 o_aux;

vec3 rotate(vec4 q, vec3 v) {
    vec3 t = 2.0 * cross(q.xyz, v);
    return v + q.w * t + cross(q.xyz, t);
}

// Pixel of camera-frame direction c; false when behind the camera or far outside the image.
bool project_pixel(vec3 c, out vec2 px) {
    px = vec2(0.0);
    if (!(c.z < 0.0)) return false;
    float x = c.x / -c.z, y = -c.y / -c.z;
    if (abs(x) > u_limit_x || abs(y) > u_limit_y) return false;
    float r2 = x * x + y * y;
    float radial = 1.0 + r2 * (u_k1k2p1p2.x + r2 * (u_k1k2p1p2.y + r2 * u_k3));
    float xd = x * radial + 2.0 * u_k1k2p1p2.z * x * y + u_k1k2p1p2.w * (r2 + 2.0 * x * x);
    float yd = y * radial + u_k1k2p1p2.z * (r2 + 2.0 * y * y) + 2.0 * u_k1k2p1p2.w * x * y;
    px = vec2(u_focal_centre.x * xd + u_focal_centre.z, u_focal_centre.y * yd + u_focal_centre.w);
    return true;
}

// Pixel of world direction d, seen by the row whose view sees it (rolling shutter).
bool texel_pixel(vec3 d, out vec2 px) {
    vec3 c = rotate(u_camera_from_world, d);
    if (!project_pixel(c, px)) return false;
    if (u_omega != vec3(0.0)) {
        for (int it = 0; it < 2; ++it) {
            // Row v's orientation is the frame's x exp(omega dt(v)): turn by exp(-omega dt).
            vec3 a = -u_omega * ((px.y - u_mid_row) * u_row_s);
            float angle = length(a);
            vec4 q = angle > 0.0 ? vec4(sin(0.5 * angle) * a / angle, cos(0.5 * angle)) : vec4(0.0, 0.0, 0.0, 1.0);
            if (!project_pixel(rotate(q, c), px)) return false;
        }
    }
    return true;
}

// Grid position of a pixel (HdrAccumulator::grid_coordinate), clamped to the cell centres.
vec2 grid_of(vec2 px) {
    float s = float(u_s);
    return clamp((px - 0.5 * (s - 1.0)) / s, vec2(0.0), vec2(textureSize(u_p, 0) - 1));
}

// Bilinear read of the planes at grid position g (HdrAccumulator::sample_planes): false when one
// of the four cells is invalid.
bool read_planes(vec2 g, out vec3 x, out vec3 w) {
    ivec2 size = textureSize(u_p, 0);
    ivec2 g0 = min(ivec2(g), size - 2);
    vec2 f = g - vec2(g0);
    vec4 p00 = texelFetch(u_p, g0, 0), p01 = texelFetch(u_p, g0 + ivec2(1, 0), 0);
    vec4 p10 = texelFetch(u_p, g0 + ivec2(0, 1), 0), p11 = texelFetch(u_p, g0 + ivec2(1, 1), 0);
    x = mix(mix(p00.rgb, p01.rgb, f.x), mix(p10.rgb, p11.rgb, f.x), f.y);
    w = mix(mix(texelFetch(u_w, g0, 0).rgb, texelFetch(u_w, g0 + ivec2(1, 0), 0).rgb, f.x),
            mix(texelFetch(u_w, g0 + ivec2(0, 1), 0).rgb, texelFetch(u_w, g0 + ivec2(1, 1), 0).rgb, f.x), f.y);
    return !(max(max(p00.a, p01.a), max(p10.a, p11.a)) > 0.0);
}

void main() {
    int i = int(gl_FragCoord.x);
    int j = u_map_size.y - 1 - int(gl_FragCoord.y);  // row 0 of the map is the top
    float theta = row_theta(j, u_map_size.y), phi = column_phi(i, u_map_size.x);
    vec2 px;
    if (!texel_pixel(vec3(sin(theta) * sin(phi), cos(theta), -sin(theta) * cos(phi)), px)) discard;
    if (px.x < 0.0 || px.y < 0.0 || px.x > u_image_size.x - 1.0 || px.y > u_image_size.y - 1.0) discard;
    vec2 g = grid_of(px);
    vec3 x, w;
    bool valid = read_planes(g, x, w);
    ivec2 nearest = clamp(ivec2(floor(g + 0.5)), ivec2(0), textureSize(u_p, 0) - 1);
    if (u_taps > 0 && texelFetch(u_w, nearest, 0).a > 0.0) {
        // In the footprint zone (w's alpha): the frame's mean over the texel's footprint,
        // u_taps x u_taps points weighed by their sub-row's solid angle, invalid when a tap
        // touches a clipped cell (HdrAccumulator::footprint_read).
        vec3 xs = vec3(0.0), ws = vec3(0.0);
        float wsum = 0.0;
        bool all_valid = true;
        float n = float(u_taps);
        // Four times the sub-rows in the two rows round each pole (footprint_read).
        int sub_rows = j < 2 || j >= u_map_size.y - 2 ? 4 * u_taps : u_taps;
        float nr = float(sub_rows);
        for (int b = 0; b < sub_rows; ++b) {
            float y0 = float(j) + float(b) / nr, y1 = float(j) + float(b + 1) / nr;
            // The sub-row's solid angle and its middle by area, in forms stable near the poles.
            float tm = 0.5 * PI * (y0 + y1) / float(u_map_size.y), d = 0.5 * PI * (y1 - y0) / float(u_map_size.y);
            float w_row = 2.0 * sin(tm) * sin(d);
            float sh = sin(0.5 * tm), sd = sin(0.5 * d);
            float one_minus_cos = 2.0 * (sh * sh + cos(tm) * sd * sd);
            float cos_t = 1.0 - one_minus_cos, sin_t = sqrt(max(0.0, one_minus_cos * (2.0 - one_minus_cos)));
            for (int a = 0; a < u_taps; ++a) {
                float ph = 2.0 * PI * (float(i) + (float(a) + 0.5) / n) / float(u_map_size.x) - PI;
                vec2 tp;
                if (!texel_pixel(vec3(sin_t * sin(ph), cos_t, -sin_t * cos(ph)), tp)) continue;
                if (tp.x < 0.0 || tp.y < 0.0 || tp.x > u_image_size.x - 1.0 || tp.y > u_image_size.y - 1.0) continue;
                vec3 tx, tw;
                all_valid = read_planes(grid_of(tp), tx, tw) && all_valid;
                xs += w_row * tx;
                ws += w_row * tw;
                wsum += w_row;
            }
        }
        if (wsum > 0.0) {
            x = xs / wsum;
            w = ws / wsum;
            valid = valid && all_valid;
        }
    }
    if (!valid) {
        // No sample, but counted in den's alpha: merge_bands leaves out a band whose reads here
        // were partly clipped when a shorter band measured the texel.
        o_num = vec4(0.0);
        o_den = vec4(0.0, 0.0, 0.0, 1.0);
        o_aux = vec4(0.0);
        return;
    }
    float wmean = (w.r + w.g + w.b) / 3.0;
    o_num = vec4(u_t * w * x, u_t * wmean);
    o_den = vec4(w * (u_t * u_t), 0.0);
    // aux: the weight, a sample counted in coverage, and a read that did not clip (merge_bands).
    o_aux = vec4(wmean, wmean >= u_min_weight ? 1.0 : 0.0, 1.0, 0.0);
}
