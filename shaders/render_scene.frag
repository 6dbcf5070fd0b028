#version 300 es
// The object's shading (docs/conventions.md, "Shading"; docs/render.md):
//   L_o = kd * E_d(N) * ao + ks * E_s^n(R),   R = reflect(V, N), V from the eye to the surface,
// into four float targets: the radiance (alpha 1 on the object), the unit world-space normal,
// the unit reflection direction, and the frame's HDR radiance (what the tone map reads).
precision highp float;
#include "equirect.glsl"
#include "render_lookup.glsl"
uniform highp sampler2D u_irradiance;
uniform highp sampler2D u_reflection;
uniform bool u_diffuse;   // kd > 0: the irradiance map is bound
uniform bool u_specular;  // ks > 0: the reflection map is bound
uniform float u_reflection_lobe;  // > 0: the map is read through this lobe (report.json "lookup": "lobe")
// x > 0: the map has fine tiles packed below it (equirect_tiled's geometry and rows)
uniform ivec4 u_reflection_tiles;
uniform ivec2 u_reflection_tile_rows;
uniform vec3 u_eye;
uniform vec3 u_kd;
uniform vec3 u_ks;
uniform float u_radiance_cap;  // 65504 into half-float targets (renderer.cpp), else float's largest
in vec3 v_normal;
in float v_ao;  // baked ambient occlusion, interpolated; multiplies the diffuse term only
in vec3 v_world;
layout(location = 0) out vec4 o_radiance;
layout(location = 1) out vec4 o_normal;
layout(location = 2) out vec4 o_reflect;
layout(location = 3) out vec4 o_hdr;

void main() {
    vec3 n = normalize(v_normal);
    vec3 v = normalize(v_world - u_eye);
    vec3 r = normalize(reflect(v, n));
    vec3 radiance = vec3(0.0);
    if (u_diffuse) radiance += u_kd * equirect_bilinear(u_irradiance, n) * v_ao;
    if (u_specular)
        radiance += u_ks * (u_reflection_lobe > 0.0 ? equirect_lobe(u_reflection, r, u_reflection_lobe)
                            : u_reflection_tiles.x > 0 ? equirect_tiled(u_reflection, r, u_reflection_tiles, u_reflection_tile_rows)
                                                       : equirect_bilinear(u_reflection, r));
    radiance = min(radiance, vec3(u_radiance_cap));
    o_radiance = vec4(radiance, 1.0);
    o_normal = vec4(n, 1.0);
    o_reflect = vec4(r, 1.0);
    o_hdr = vec4(radiance, 1.0);
}
