#version 300 es
// Shading of docs/conventions.md: L = kd E_d(N) + ks E_s^n(R), with E_d and
// E_s^n looked up in equirect maps (bilinear, wrapping in azimuth).
precision highp float;
#include "equirect.glsl"
uniform highp sampler2D u_irradiance;
uniform highp sampler2D u_reflection;
uniform vec3 u_eye;
uniform vec3 u_kd;
uniform vec3 u_ks;
in vec3 v_normal;
in vec3 v_world;
out vec4 o_color;

vec2 equirect_uv(vec3 d) {
    float phi = atan(d.x, -d.z);
    float theta = acos(clamp(d.y, -1.0, 1.0));
    return vec2((phi + PI) / TWO_PI, theta / PI);
}

void main() {
    vec3 n = normalize(v_normal);
    vec3 v = normalize(v_world - u_eye);
    vec3 r = reflect(v, n);
    vec3 color = u_kd * texture(u_irradiance, equirect_uv(n)).rgb + u_ks * texture(u_reflection, equirect_uv(r)).rgb;
    o_color = vec4(color / (1.0 + color), 1.0);  // a simple tone map for the screen
}
