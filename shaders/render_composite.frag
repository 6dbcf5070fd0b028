#version 300 es
// The display's frame (with fullscreen.vert): the object's radiance where it covers the pixel
// (alpha 1 in the radiance target), else the environment seen through the camera (the same ray
// and lookup as render_background.frag) when it is the background, both through Reinhard's
// global operator (Reinhard et al. 2002, eq. 2 and 4) and the sRGB transfer curve; else the
// background image as it is (already display-encoded), or black.
//   L_s = key / L_avg * L,   L_d = L_s (1 + L_s / L_white^2) / (1 + L_s),   rgb_d = rgb * L_d / L
// The environment is looked up here rather than drawn into a float target first: one full-screen
// float target less to write and read each frame.
// With shadows on, the background (environment or image, never the object) is multiplied by the
// table's shadow ratio (render_shadow.glsl), evaluated here for the background pixels that no
// proxy covers (a
// target of its own would cost a full-screen float pass a frame); the image in linear light,
// through the sRGB curve and back.
// The program is compiled per variant (renderer.cpp, composite_program): these are defines, not
// uniforms, because a software rasteriser (llvmpipe) runs both sides of a branch on a uniform for
// every pixel. The unused table search and shadow once cost 20 of a 27 ms frame at 320x180.
//   BACKGROUND: 0 black, 1 an image, 2 the environment
//   CAMERA: 0 Reinhard and sRGB, 1 the camera's parametric curve, 2 its table
//   SHADOW: 0 none; 1 the table's shadow on the background; 2 the same from the baked grid
//   alone, where it holds the whole shadow (ShadowBake::open_beyond): the spheres' model is
//   compiled out (it cost 15 of 17 ms at 320x180)
//   NOISE: 1 the sensor's noise on virtual pixels (with CAMERA 1 or 2: it is in exposure units)
//   BLUR: 1 the object smeared along its motion during the exposure
// (docs/render.md, "Matching the camera").
#ifndef BACKGROUND
#define BACKGROUND 0
#endif
#ifndef CAMERA
#define CAMERA 0
#endif
#ifndef SHADOW
#define SHADOW 0
#endif
#ifndef NOISE
#define NOISE 0
#endif
#ifndef BLUR
#define BLUR 0
#endif
#if SHADOW == 2
#define SHADOW_BAKE_ONLY 1
#endif
precision highp float;
// The noise's hash needs 32-bit integers: ES's default for them in a fragment shader is mediump,
// which Mesa runs in 16 bits (every hash then fell below 256).
precision highp int;
#include "equirect.glsl"
#include "render_lookup.glsl"
#include "render_shadow.glsl"
uniform highp sampler2D u_radiance;
uniform highp sampler2D u_environment;
uniform mediump sampler2D u_image;
uniform highp sampler2D u_normal;  // alpha -1 where a proxy (a real thing) hides the table
uniform vec2 u_size;
uniform vec2 u_tan_half_fov;  // tan(fov_x / 2), tan(fov_y / 2)
uniform mat3 u_world_from_camera;
uniform float u_scale;      // key / L_avg
uniform float u_white_sq;   // L_white^2, in scaled luminance
// The camera's response instead of Reinhard and sRGB (camera_response.hpp): X = radiance x
// u_camera_scale, code = forward(X): the parametric curve (CAMERA 1), else the table u_response
// (inverse[z] at texel z) inverted piecewise linearly (CAMERA 2). Image codes decode to inverse[z].
uniform float u_camera_scale;
uniform float u_gamma;
uniform float u_shoulder;
uniform highp sampler2D u_response;
uniform vec2 u_noise;     // variance of X: x X + y (gain / full well, read noise^2)
uniform uint u_seed;      // the frame's: a new noise pattern each frame
uniform vec2 u_blur;      // the object's motion on screen during the exposure, pixels
uniform int u_blur_taps;
out vec4 o_color;

#if NOISE
// A hash per pixel, channel and frame (PCG, O'Neill 2014: the output permutation of one LCG step),
// made Gaussian by Box-Muller: no texture, no state between frames.
uint pcg(uint v) {
    uint state = v * 747796405u + 2891336453u;
    uint word = ((state >> ((state >> 28u) + 4u)) ^ state) * 277803737u;
    return (word >> 22u) ^ word;
}
float unit_open(uint h) { return (float(h >> 8u) + 0.5) / 16777216.0; }  // in (0, 1)
vec3 gaussian3() {
    uvec2 p = uvec2(gl_FragCoord.xy);
    uint h = pcg(p.x ^ pcg(p.y ^ pcg(u_seed)));
    uint h1 = pcg(h), h2 = pcg(h1 ^ 0x9e3779b9u), h3 = pcg(h2 ^ 0x85ebca6bu), h4 = pcg(h3 ^ 0xc2b2ae35u);
    float r1 = sqrt(-2.0 * log(unit_open(h1))), r2 = sqrt(-2.0 * log(unit_open(h3)));
    float a1 = 6.2831853 * unit_open(h2), a2 = 6.2831853 * unit_open(h4);
    return vec3(r1 * cos(a1), r1 * sin(a1), r2 * cos(a2));
}
// Relative exposure as the sensor would record it: shot and read noise.
vec3 sensor_noise(vec3 x) { return x + sqrt(max(x, 0.0) * u_noise.x + u_noise.y) * gaussian3(); }
#else
vec3 sensor_noise(vec3 x) { return x; }
#endif

// The object's radiance target at this pixel: premultiplied RGB and coverage, averaged along the
// object's path during the exposure with BLUR (a box filter of the smear, as the sensor
// integrates it; the background behind is the video's, already blurred by the real motion).
vec4 object_at_pixel() {
#if BLUR
    vec4 sum = vec4(0.0);
    ivec2 last = ivec2(u_size) - 1;
    for (int k = 0; k < u_blur_taps; ++k) {
        float t = (float(k) + 0.5) / float(u_blur_taps) - 0.5;
        ivec2 q = clamp(ivec2(floor(gl_FragCoord.xy + t * u_blur)), ivec2(0), last);
        sum += texelFetch(u_radiance, q, 0);
    }
    return sum / float(u_blur_taps);
#else
    return texelFetch(u_radiance, ivec2(gl_FragCoord.xy), 0);
#endif
}

vec3 srgb_encode(vec3 c) {
    c = clamp(c, 0.0, 1.0);
    return mix(12.92 * c, 1.055 * pow(c, vec3(1.0 / 2.4)) - 0.055, step(0.0031308, c));
}

vec3 srgb_decode(vec3 c) {
    return mix(c / 12.92, pow((c + 0.055) / 1.055, vec3(2.4)), step(0.04045, c));
}

vec3 reinhard(vec3 hdr) {
    float l = dot(hdr, vec3(0.2126, 0.7152, 0.0722));
    float ls = u_scale * l;
    float ld = ls * (1.0 + ls / u_white_sq) / (1.0 + ls);
    return l > 0.0 ? hdr * (ld / l) : vec3(0.0);
}

// The radiance target's alpha is the object's coverage of the pixel: 0 or 1 without MSAA, the
// mean of the samples with it (RGB premultiplied, as the resolve averages). Partly covered pixels
// mix the object and the background: in HDR before the tone map over the environment (the light
// that reaches the pixel), in linear light after it over an image or black.
float inverse_response(int z) { return texelFetch(u_response, ivec2(z, 0), 0).r; }

float camera_code(float x) {
#if CAMERA == 1
    if (x <= 0.0) return 0.0;
    float root = pow(x, 1.0 / u_gamma);
    return min(255.0, 255.0 * (1.0 + u_shoulder) * root / (root + u_shoulder));
#else
    if (x <= inverse_response(0)) return 0.0;
    if (x >= inverse_response(255)) return 255.0;
    int lo = 0, hi = 255;  // inverse(lo) <= x < inverse(hi)
    for (int k = 0; k < 8; ++k) {
        int mid = (lo + hi) / 2;
        if (inverse_response(mid) <= x) lo = mid; else hi = mid;
    }
    return float(lo) + (x - inverse_response(lo)) / (inverse_response(hi) - inverse_response(lo));
#endif
}

// Linear light (relative exposure with the camera) to the display's code, and back for an image.
#if CAMERA == 0
vec3 encode(vec3 linear) { return srgb_encode(linear); }
vec3 decode(vec3 c) { return srgb_decode(c); }
// HDR radiance to linear display light: Reinhard's operator.
vec3 expose(vec3 hdr) { return reinhard(hdr); }
#else
vec3 encode(vec3 linear) { return vec3(camera_code(linear.r), camera_code(linear.g), camera_code(linear.b)) / 255.0; }
vec3 decode(vec3 c) {
    ivec3 z = ivec3(round(clamp(c, 0.0, 1.0) * 255.0));
    return vec3(inverse_response(z.r), inverse_response(z.g), inverse_response(z.b));
}
// HDR radiance to linear display light: the camera's exposure.
vec3 expose(vec3 hdr) { return u_camera_scale * hdr; }
#endif

void main() {
    vec4 object = object_at_pixel();
    vec2 ndc = gl_FragCoord.xy / u_size * 2.0 - 1.0;
    vec3 ray = normalize(u_world_from_camera * vec3(ndc * u_tan_half_fov, -1.0));
#if SHADOW
    bool proxy = texelFetch(u_normal, ivec2(gl_FragCoord.xy), 0).a < 0.0;
    vec3 shadow = object.a < 1.0 && !proxy ? table_shadow(ray).rgb : vec3(1.0);
#else
    vec3 shadow = vec3(1.0);
#endif
    if (object.a >= 1.0) {
        o_color = vec4(encode(sensor_noise(expose(object.rgb))), 1.0);
        return;
    }
#if BACKGROUND == 2
    // The environment is virtual too: the whole pixel gets the sensor's noise.
    vec3 background = shadow * equirect_bilinear(u_environment, ray);
    o_color = vec4(encode(sensor_noise(expose(object.rgb + (1.0 - object.a) * background))), 1.0);
#else
    // The image's rows are top first; the frame's y grows upwards.
    vec2 uv = vec2(gl_FragCoord.x / u_size.x, 1.0 - gl_FragCoord.y / u_size.y);
#if BACKGROUND == 1
    vec3 image = texture(u_image, uv).rgb;
#if SHADOW
    // Only where the table is in shadow: elsewhere the image is shown as it came.
    if (any(lessThan(shadow, vec3(1.0)))) image = encode(shadow * decode(image));
#endif
#else
    vec3 image = vec3(0.0);
#endif
    if (object.a > 0.0) {
        vec3 front = object.a * sensor_noise(expose(object.rgb / object.a));
        image = encode(front + (1.0 - object.a) * decode(image));
    }
    o_color = vec4(image, 1.0);
#endif
}
