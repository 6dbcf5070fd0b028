// The object's shadow on the table plane y = u_table_height, as a ratio of the table's irradiance
// with the object to without it (appliance/render/shadow.hpp, docs/render.md):
//   ratio = (sum_i E_i V_i + E_a - O_a) / (sum_i E_i + E_a)
// V_i: the visible part of light i's disc (angular radius beta) past every occluder sphere;
// O_a: the ambient irradiance the spheres take (from maps of the ambient's irradiance per cap).
// Evaluated where it is shown (render_composite.frag, render_background.frag) and into a target
// for the AOV (render_shadow.frag). Needs equirect.glsl and render_lookup.glsl included before it.
// SHADOW_BAKE_ONLY 1 (a frame whose bake holds the whole shadow): inside the baked grid as ever,
// beyond it the table is open (1); the spheres' model is not compiled.
#ifndef SHADOW_BAKE_ONLY
#define SHADOW_BAKE_ONLY 0
#endif
#define MAX_LIGHTS 4
#define MAX_SPHERES 64
uniform vec3 u_eye;
uniform float u_table_height;
uniform int u_light_count;
uniform vec3 u_light_dir[MAX_LIGHTS];         // unit, towards the light
uniform float u_light_radius[MAX_LIGHTS];     // angular radius, radians
uniform vec3 u_light_irradiance[MAX_LIGHTS];  // E_i on the unshadowed table
uniform vec3 u_ambient_irradiance;            // E_a on the unshadowed table
// The table's irradiance from the ambient part within caps of radius u_cap_radius[l] around each
// direction, per steradian of cap (level 0: the part times its cosine to +Y): CAP_LEVELS maps of
// CAP_W x CAP_H stacked top to bottom in one texture, so one texel position serves every level.
#define CAP_LEVELS 7
#define CAP_W 64
#define CAP_H 32
uniform float u_cap_radius[CAP_LEVELS];
uniform highp sampler2D u_caps;
uniform int u_sphere_count;
uniform vec4 u_spheres[MAX_SPHERES];          // centre, radius
uniform vec4 u_bound;                         // a sphere around all of them
// The baked shadow (shadow_bake.hpp): inside its grid on the table, each light's visible part
// (RGBA: lights 0..3) and the share of the ambient left (RGB), from rays against the real mesh.
uniform bool u_has_bake;
uniform highp sampler2D u_bake_lights;
uniform highp sampler2D u_bake_ambient;
uniform vec2 u_bake_origin;   // (x, z) of grid point (0, 0)
uniform float u_bake_spacing;
uniform int u_bake_res;

vec4 bake_bilinear(highp sampler2D t, ivec2 i0, vec2 f) {
    vec4 top = mix(texelFetch(t, i0, 0), texelFetch(t, i0 + ivec2(1, 0), 0), f.x);
    vec4 bottom = mix(texelFetch(t, i0 + ivec2(0, 1), 0), texelFetch(t, i0 + ivec2(1, 1), 0), f.x);
    return mix(top, bottom, f.y);
}

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
    if (alpha + beta < PI && dot(l, w) <= cos(alpha + beta)) return 0.0;  // apart: no atan needed
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

// The table's irradiance per steradian from the ambient within the cap of angular radius alpha
// around d: the two levels around alpha, each looked up bilinearly (as equirect_bilinear, at the
// same texel position), mixed linearly in the radius.
vec3 cap_density(vec3 d, float alpha) {
    int l = 0;
    while (l < CAP_LEVELS - 2 && u_cap_radius[l + 1] < alpha) ++l;
    float f = clamp((alpha - u_cap_radius[l]) / (u_cap_radius[l + 1] - u_cap_radius[l]), 0.0, 1.0);
    vec2 t = equirect_texel(d, ivec2(CAP_W, CAP_H));
    float x = t.x - 0.5;
    float y = clamp(t.y - 0.5, 0.0, float(CAP_H - 1));
    float fx = floor(x), fy = floor(y);
    float ax = x - fx, ay = y - fy;
    int x0 = int(fx);
    if (x0 < 0) x0 += CAP_W;
    if (x0 >= CAP_W) x0 -= CAP_W;
    int x1 = x0 + 1 == CAP_W ? 0 : x0 + 1;
    int y0 = int(fy);
    int y1 = min(y0 + 1, CAP_H - 1);
    vec3 level[2];
    for (int k = 0; k < 2; ++k) {
        int o = (l + k) * CAP_H;
        vec3 top = mix(texelFetch(u_caps, ivec2(x0, o + y0), 0).rgb, texelFetch(u_caps, ivec2(x1, o + y0), 0).rgb, ax);
        vec3 bottom = mix(texelFetch(u_caps, ivec2(x0, o + y1), 0).rgb, texelFetch(u_caps, ivec2(x1, o + y1), 0).rgb, ax);
        level[k] = mix(top, bottom, ay);
    }
    return mix(level[0], level[1], f);
}

// The ratio where the camera ray `ray` (unit, world) from u_eye meets the table: (ratio, 1), or
// (1, 1, 1, 0) when it misses the table.
vec4 table_shadow(vec3 ray) {
    float t = (u_table_height - u_eye.y) / ray.y;
    if (!(ray.y < 0.0) || !(t > 0.0)) {
        return vec4(1.0, 1.0, 1.0, 0.0);
    }
    vec3 p = u_eye + t * ray;
#if SHADOW_BAKE_ONLY
    {
#else
    if (u_has_bake) {
#endif
        vec2 g = (p.xz - u_bake_origin) / u_bake_spacing;
        float last = float(u_bake_res - 1);
        if (g.x >= 0.0 && g.y >= 0.0 && g.x <= last && g.y <= last) {
            ivec2 i0 = ivec2(min(floor(g), vec2(last - 1.0)));
            vec2 f = g - vec2(i0);
            vec4 v = bake_bilinear(u_bake_lights, i0, f);
            vec3 baked = u_ambient_irradiance * bake_bilinear(u_bake_ambient, i0, f).rgb;
            vec3 open = u_ambient_irradiance;
            for (int i = 0; i < u_light_count; ++i) {
                baked += u_light_irradiance[i] * v[i];
                open += u_light_irradiance[i];
            }
            vec3 r = vec3(1.0);
            for (int c = 0; c < 3; ++c)
                if (open[c] > 0.0) r[c] = clamp(baked[c] / open[c], 0.0, 1.0);
            return vec4(r, 1.0);
        }
    }
#if SHADOW_BAKE_ONLY
    return vec4(1.0, 1.0, 1.0, 1.0);
#else
    float visible[MAX_LIGHTS];
    for (int i = 0; i < MAX_LIGHTS; ++i) visible[i] = 1.0;
    // The part of the ambient irradiance left: each sphere takes its share of what is left, as if
    // the spheres hid independent parts of the sky (exact for one sphere; several overlapping
    // spheres, a mesh's cells, would take far too much if their shares were added).
    vec3 left = vec3(1.0);
    vec3 inv_ambient = vec3(1.0) / max(u_ambient_irradiance, vec3(1e-30));
    // The bound first: where it hides no light, no sphere inside it does; where it takes under
    // 1e-3 of the sky, they take less. Far from a mesh of many cells this skips them all.
    vec3 tb = u_bound.xyz - p;
    float db = length(tb);
    float sb = min(1.0, u_bound.w / db);
    float ab = asin(sb);
    bool lights_hidden = false;
    for (int i = 0; i < u_light_count; ++i)
        lights_hidden = lights_hidden || covered(u_light_dir[i], u_light_radius[i], tb / db, ab) > 0.0;
    float cap_b = TWO_PI * (1.0 - sqrt(max(0.0, 1.0 - sb * sb)));
    bool sky_taken = any(greaterThan(cap_b * cap_density(tb / db, ab) * inv_ambient, vec3(1e-3)));
    int spheres = lights_hidden || sky_taken ? u_sphere_count : 0;
    for (int s = 0; s < spheres; ++s) {
        vec3 to = u_spheres[s].xyz - p;
        float dist = length(to);
        vec3 w = to / dist;
        float sin_a = min(1.0, u_spheres[s].w / dist);
        float alpha = asin(sin_a);
        if (lights_hidden)
            for (int i = 0; i < u_light_count; ++i)
                visible[i] *= 1.0 - covered(u_light_dir[i], u_light_radius[i], w, alpha);
        // The ambient irradiance from the sphere's cap, solid angle 2 pi (1 - cos a).
        float cap = TWO_PI * (1.0 - sqrt(max(0.0, 1.0 - sin_a * sin_a)));
        if (sky_taken) left *= max(vec3(0.0), vec3(1.0) - cap * cap_density(w, alpha) * inv_ambient);
    }
    vec3 lit = u_ambient_irradiance * left;
    vec3 unshadowed = u_ambient_irradiance;
    for (int i = 0; i < u_light_count; ++i) {
        lit += u_light_irradiance[i] * visible[i];
        unshadowed += u_light_irradiance[i];
    }
    vec3 ratio = vec3(1.0);
    for (int c = 0; c < 3; ++c)
        if (unshadowed[c] > 0.0) ratio[c] = clamp(lit[c] / unshadowed[c], 0.0, 1.0);
    return vec4(ratio, 1.0);
#endif
}
