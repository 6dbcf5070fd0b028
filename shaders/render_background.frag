#version 300 es
// The environment seen through the camera, behind the object, into the HDR target that the tone
// map meters (with fullscreen.vert): each pixel's ray in world space (the camera looks along -Z
// with +Y up; docs/render.md), the environment looked up bilinearly along it. Radiance, normal
// and reflection stay 0 off the object. (Frames look the environment up in render_composite.frag.)
precision highp float;
#include "equirect.glsl"
#include "render_lookup.glsl"
#include "render_shadow.glsl"
uniform highp sampler2D u_environment;
uniform vec2 u_size;          // the frame in pixels
uniform vec2 u_tan_half_fov;  // tan(fov_x / 2), tan(fov_y / 2)
uniform mat3 u_world_from_camera;
uniform bool u_has_shadow;  // the table's shadow darkens the environment, as in the frame (render_shadow.glsl)
uniform float u_radiance_cap;  // as render_scene.frag
layout(location = 0) out vec4 o_radiance;
layout(location = 1) out vec4 o_normal;
layout(location = 2) out vec4 o_reflect;
layout(location = 3) out vec4 o_hdr;

void main() {
    vec2 ndc = gl_FragCoord.xy / u_size * 2.0 - 1.0;
    vec3 ray = normalize(u_world_from_camera * vec3(ndc * u_tan_half_fov, -1.0));
    o_radiance = vec4(0.0);
    o_normal = vec4(0.0);
    o_reflect = vec4(0.0);
    vec3 shadow = u_has_shadow ? table_shadow(ray).rgb : vec3(1.0);
    o_hdr = vec4(min(shadow * equirect_bilinear(u_environment, ray), vec3(u_radiance_cap)), 1.0);
}
