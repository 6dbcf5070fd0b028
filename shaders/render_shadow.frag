#version 300 es
// The table's shadow ratio into a target for the AOV shadow.exr (with fullscreen.vert): RGB = the
// ratio, A = 1 where the pixel's camera ray meets the table (render_shadow.glsl).
precision highp float;
#include "equirect.glsl"
#include "render_lookup.glsl"
#include "render_shadow.glsl"
uniform vec2 u_size;
uniform vec2 u_tan_half_fov;  // tan(fov_x / 2), tan(fov_y / 2)
uniform mat3 u_world_from_camera;
layout(location = 0) out vec4 o_shadow;

void main() {
    vec2 ndc = gl_FragCoord.xy / u_size * 2.0 - 1.0;
    o_shadow = table_shadow(normalize(u_world_from_camera * vec3(ndc * u_tan_half_fov, -1.0)));
}
