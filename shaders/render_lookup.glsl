// Bilinear lookup of an equirect map (docs/conventions.md, "Maps of another size") by direction,
// the same arithmetic as sample_bilinear in appliance/core/equirect.cpp: wrap in azimuth (column
// W-1 blends with column 0), clamp in polar angle (the first and last rows hold to the poles).
// Done with texelFetch on RGBA32F textures rather than the sampler's filtering, so it needs no
// OES_texture_float_linear and its weights are full float (llvmpipe's filter weights are not).
// Needs equirect.glsl (PI, TWO_PI) included before it.

// Continuous texel coordinates of a unit direction: x = (phi + pi) / 2pi * W, y = theta / pi * H.
// theta from atan(|xz|, y) rather than acos(y): acos loses precision near the poles.
vec2 equirect_texel(vec3 d, ivec2 size) {
    float phi = atan(d.x, -d.z);
    float theta = atan(length(d.xz), d.y);
    return vec2((phi + PI) / TWO_PI * float(size.x), theta / PI * float(size.y));
}

vec3 equirect_bilinear(highp sampler2D map, vec3 d) {
    ivec2 size = textureSize(map, 0);
    vec2 t = equirect_texel(d, size);
    float x = t.x - 0.5;
    float y = clamp(t.y - 0.5, 0.0, float(size.y - 1));
    float fx = floor(x);
    float fy = floor(y);
    float ax = x - fx;
    float ay = y - fy;
    // x is in [-0.5, W - 0.5], so fx in [-1, W - 1] (GLSL ES leaves % of negatives undefined).
    int x0 = int(fx);
    if (x0 < 0) x0 += size.x;
    if (x0 >= size.x) x0 -= size.x;
    int x1 = x0 + 1 == size.x ? 0 : x0 + 1;
    int y0 = int(fy);
    int y1 = min(y0 + 1, size.y - 1);
    vec3 top = mix(texelFetch(map, ivec2(x0, y0), 0).rgb, texelFetch(map, ivec2(x1, y0), 0).rgb, ax);
    vec3 bottom = mix(texelFetch(map, ivec2(x0, y1), 0).rgb, texelFetch(map, ivec2(x1, y1), 0).rgb, ax);
    return mix(top, bottom, ay);
}
