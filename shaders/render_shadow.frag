#version 300 es
// The object's shadow on the table plane y = u_table_height, as a ratio of the table's irradiance
// with the object to without it (appliance/render/shadow.hpp, docs/render.md), with
// fullscreen.vert. RGB = the ratio, A = 1 where the pixel's camera ray meets the table.
//   ratio = (sum_i E_i V_i + E_a - O_a) / (sum_i E_i + E_a)
// V_i: the visible part of light i's disc (angular radius beta) past every occluder sphere;
// O_a: the ambient irradiance the spheres take (from maps of the ambient's irradiance per cap).
precision highp float;
#include "equirect.glsl"
#include "render_lookup.glsl"
#define MAX_LIGHTS 4
#define MAX_SPHERES 64
uniform vec2 u_size;
uniform vec2 u_tan_half_fov;  // tan(fov_x / 2), tan(fov_y / 2)
uniform mat3 u_world_from_camera;
uniform vec3 u_eye;
uniform float u_table_height;
uniform int u_light_count;
uniform vec3 u_light_dir[MAX_LIGHTS];         // unit, towards the light
uniform float u_light_radius[MAX_LIGHTS];     // angular radius, radians
uniform vec3 u_light_irradiance[MAX_LIGHTS];  // E_i on the unshadowed table
uniform vec3 u_ambient_irradiance;            // E_a on the unshadowed table
// The table's irradiance from the ambient part within caps of radius u_cap_radius[l] around each
// direction, per steradian of cap (u_cap0: the part times its cosine to +Y), 64x32.
#define CAP_LEVELS 7
uniform float u_cap_radius[CAP_LEVELS];
uniform highp sampler2D u_cap0;
uniform highp sampler2D u_cap1;
uniform highp sampler2D u_cap2;
uniform highp sampler2D u_cap3;
uniform highp sampler2D u_cap4;
uniform highp sampler2D u_cap5;
uniform highp sampler2D u_cap6;
uniform int u_sphere_count;
uniform vec4 u_spheres[MAX_SPHERES];          // centre, radius
layout(location = 0) out vec4 o_shadow;

// Area of the overlap of two discs of radii a and b whose centres are d apart.
float lens(float a, float b, float d) {
    if (d >= a + b) return 0.0;
    float m = min(a, b);
    if (d <= abs(a - b)) return PI * m * m;
    float ca = clamp((d * d + a * a - b * b) / (2.0 * d * a), -1.0, 1.0);
    float cb = clamp((d * d + b * b - a * a) / (2.0 * d * b), -1.0, 1.0);
    float k = max(0.0, (-d + a + b) * (d + a - b) * (d - a + b) * (d + a + b));
    return a * a * acos(ca) + b * b * acos(cb) - 0.5 * sqrt(k);
}

// The part of a light's disc (centre l, angular radius beta) that a sphere's disc (centre w,
// angular radius alpha) covers, in the light's tangent plane: there the sphere's edge, a circle of
// angular radius alpha on the unit sphere, curves with radius tan(alpha) and passes at
// gamma - alpha from the light's centre. Nearly straight edges are a half-plane.
float covered(vec3 l, float beta, vec3 w, float alpha) {
    float gamma = atan(length(cross(l, w)), dot(l, w));
    float edge = gamma - alpha;  // > 0: the light's centre is outside the sphere's disc
    if (edge >= beta) return 0.0;
    float big = tan(min(alpha, 1.5));
    if (alpha >= 1.5 || big > 64.0 * beta) {
        if (edge <= -beta) return 1.0;
        float s = edge / beta;
        return (acos(s) - s * sqrt(max(0.0, 1.0 - s * s))) / PI;
    }
    return min(1.0, lens(big, beta, big + edge) / (PI * beta * beta));
}

// GLSL ES indexes sampler arrays only with constants: one branch per level.
vec3 cap_level(int l, vec3 d) {
    if (l <= 0) return equirect_bilinear(u_cap0, d);
    if (l == 1) return equirect_bilinear(u_cap1, d);
    if (l == 2) return equirect_bilinear(u_cap2, d);
    if (l == 3) return equirect_bilinear(u_cap3, d);
    if (l == 4) return equirect_bilinear(u_cap4, d);
    if (l == 5) return equirect_bilinear(u_cap5, d);
    return equirect_bilinear(u_cap6, d);
}

// The table's irradiance per steradian from the ambient within the cap of angular radius alpha
// around d: the two levels around alpha, mixed linearly in the radius.
vec3 cap_density(vec3 d, float alpha) {
    int l = 0;
    while (l < CAP_LEVELS - 2 && u_cap_radius[l + 1] < alpha) ++l;
    float f = clamp((alpha - u_cap_radius[l]) / (u_cap_radius[l + 1] - u_cap_radius[l]), 0.0, 1.0);
    return mix(cap_level(l, d), cap_level(l + 1, d), f);
}

void main() {
    vec2 ndc = gl_FragCoord.xy / u_size * 2.0 - 1.0;
    vec3 ray = normalize(u_world_from_camera * vec3(ndc * u_tan_half_fov, -1.0));
    float t = (u_table_height - u_eye.y) / ray.y;
    if (!(ray.y < 0.0) || !(t > 0.0)) {
        o_shadow = vec4(1.0, 1.0, 1.0, 0.0);
        return;
    }
    vec3 p = u_eye + t * ray;

    float visible[MAX_LIGHTS];
    for (int i = 0; i < MAX_LIGHTS; ++i) visible[i] = 1.0;
    vec3 taken = vec3(0.0);
    for (int s = 0; s < u_sphere_count; ++s) {
        vec3 to = u_spheres[s].xyz - p;
        float dist = length(to);
        vec3 w = to / dist;
        float sin_a = min(1.0, u_spheres[s].w / dist);
        float alpha = asin(sin_a);
        for (int i = 0; i < u_light_count; ++i)
            visible[i] *= 1.0 - covered(u_light_dir[i], u_light_radius[i], w, alpha);
        // The ambient irradiance from the sphere's cap, solid angle 2 pi (1 - cos a).
        float cap = TWO_PI * (1.0 - sqrt(max(0.0, 1.0 - sin_a * sin_a)));
        taken += cap * cap_density(w, alpha);
    }
    vec3 lit = max(u_ambient_irradiance - taken, vec3(0.0));
    vec3 unshadowed = u_ambient_irradiance;
    for (int i = 0; i < u_light_count; ++i) {
        lit += u_light_irradiance[i] * visible[i];
        unshadowed += u_light_irradiance[i];
    }
    vec3 ratio = vec3(1.0);
    for (int c = 0; c < 3; ++c)
        if (unshadowed[c] > 0.0) ratio[c] = clamp(lit[c] / unshadowed[c], 0.0, 1.0);
    o_shadow = vec4(ratio, 1.0);
}
