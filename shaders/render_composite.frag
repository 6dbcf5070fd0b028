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
#ifndef BACKGROUND
#define BACKGROUND 0
#endif
#ifndef CAMERA
#define CAMERA 0
#endif
#ifndef SHADOW
#define SHADOW 0
#endif
#if SHADOW == 2
#define SHADOW_BAKE_ONLY 1
#endif
precision highp float;
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
out vec4 o_color;

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
    vec4 object = texelFetch(u_radiance, ivec2(gl_FragCoord.xy), 0);
    vec2 ndc = gl_FragCoord.xy / u_size * 2.0 - 1.0;
    vec3 ray = normalize(u_world_from_camera * vec3(ndc * u_tan_half_fov, -1.0));
#if SHADOW
    bool proxy = texelFetch(u_normal, ivec2(gl_FragCoord.xy), 0).a < 0.0;
    vec3 shadow = object.a < 1.0 && !proxy ? table_shadow(ray).rgb : vec3(1.0);
#else
    vec3 shadow = vec3(1.0);
#endif
    if (object.a >= 1.0) {
        o_color = vec4(encode(expose(object.rgb)), 1.0);
        return;
    }
#if BACKGROUND == 2
    vec3 background = shadow * equirect_bilinear(u_environment, ray);
    o_color = vec4(encode(expose(object.rgb + (1.0 - object.a) * background)), 1.0);
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
        vec3 front = object.a * expose(object.rgb / object.a);
        image = encode(front + (1.0 - object.a) * decode(image));
    }
    o_color = vec4(image, 1.0);
#endif
}
