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

// The bilinear cell of continuous texel coordinates t on a grid of `size` texels, as core's
// bilinear_cell (fine_tiles.cpp) and sample_bilinear take it: columns (x0, x1) wrapped in
// azimuth, rows (y0, y1) clamped in polar angle, and the weights of x1 and y1.
struct Cell {
    int x0, x1, y0, y1;
    vec2 a;
};
Cell bilinear_cell(vec2 t, ivec2 size) {
    float x = t.x - 0.5;
    float y = clamp(t.y - 0.5, 0.0, float(size.y - 1));
    float fx = floor(x);
    float fy = floor(y);
    Cell c;
    c.a = vec2(x - fx, y - fy);
    // x is in [-0.5, W - 0.5], so fx in [-1, W - 1] (GLSL ES leaves % of negatives undefined).
    c.x0 = int(fx);
    if (c.x0 < 0) c.x0 += size.x;
    if (c.x0 >= size.x) c.x0 -= size.x;
    c.x1 = c.x0 + 1 == size.x ? 0 : c.x0 + 1;
    c.y0 = int(fy);
    c.y1 = min(c.y0 + 1, size.y - 1);
    return c;
}

// The lookup of a map held in the first size.y rows of `map` (a tiled map's texture holds more
// below: equirect_tiled).
vec3 equirect_bilinear_rows(highp sampler2D map, vec3 d, ivec2 size) {
    Cell c = bilinear_cell(equirect_texel(d, size), size);
    vec3 top = mix(texelFetch(map, ivec2(c.x0, c.y0), 0).rgb, texelFetch(map, ivec2(c.x1, c.y0), 0).rgb, c.a.x);
    vec3 bottom = mix(texelFetch(map, ivec2(c.x0, c.y1), 0).rgb, texelFetch(map, ivec2(c.x1, c.y1), 0).rgb, c.a.x);
    return mix(top, bottom, c.a.y);
}

vec3 equirect_bilinear(highp sampler2D map, vec3 d) { return equirect_bilinear_rows(map, d, textureSize(map, 0)); }

// The lookup of a map with fine tiles (core/fine_tiles.hpp, sample_bilinear(base, fine, d); the
// texture's layout in appliance/render/tiled_map.hpp): the bilinear cell of the grid `factor`
// times finer; when its top-left texel's tile is kept, the cell's four texels from that tile's
// block, else the base's own bilinear lookup. geometry: (factor, tile, base rows, blocks per band),
// rows: (slot table's first row, blocks' first row).
vec3 equirect_tiled(highp sampler2D map, vec3 d, ivec4 geometry, ivec2 rows) {
    int width = textureSize(map, 0).x;
    ivec2 base = ivec2(width, geometry.z);
    int factor = geometry.x;
    ivec2 fine = base * factor;
    Cell c = bilinear_cell(equirect_texel(d, fine), fine);
    int span = geometry.y * factor;  // fine texels per tile side
    int tx = c.x0 / span;
    int ty = c.y0 / span;
    int slot_index = ty * (width / geometry.y) + tx;
    int block = int(texelFetch(map, ivec2(slot_index % width, rows.x + slot_index / width), 0).r);
    if (block < 0) return equirect_bilinear_rows(map, d, base);
    // The block's own columns and rows: its last column is the next tile's first (round the
    // seam too) and its last row the next tile's first or, in the last tile row, the last row
    // again (the clamp at the pole).
    int side = span + 1;
    ivec2 origin = ivec2((block % geometry.w) * side, rows.y + (block / geometry.w) * side);
    int u = c.x0 - tx * span;
    int v = c.y0 - ty * span;
    int v1 = c.y1 == c.y0 ? v : v + 1;
    vec3 top = mix(texelFetch(map, origin + ivec2(u, v), 0).rgb, texelFetch(map, origin + ivec2(u + 1, v), 0).rgb, c.a.x);
    vec3 bottom = mix(texelFetch(map, origin + ivec2(u, v1), 0).rgb, texelFetch(map, origin + ivec2(u + 1, v1), 0).rgb, c.a.x);
    return mix(top, bottom, c.a.y);
}

// The lobe lookup of a map whose lobe is narrower than its texel spacing (report.json
// "lookup": "lobe"; sample_lobe in appliance/core/equirect.cpp, the same steps in float): the map
// holds the environment's own texels, and the conventions' sum E^n(d) is taken over those whose
// weight is within exp(-20) of the texel d falls in (below float's precision), found by the
// haversine of the angle to each centre, so none is missed across the seam or a pole. One pass:
// the sums are rescaled whenever a larger weight turns up (weights relative to the largest, as
// the conventions take them, never overflow).
vec3 equirect_lobe(highp sampler2D map, vec3 d, float n) {
    ivec2 size = textureSize(map, 0);
    float w = float(size.x);
    float h = float(size.y);
    // atan(0, 0) is undefined in GLSL ES: straight up or down, any azimuth will do.
    float phi_r = dot(d.xz, d.xz) > 0.0 ? atan(d.x, -d.z) : 0.0;
    float theta_r = atan(length(d.xz), d.y);
    float sin_r = sin(theta_r);
    float dphi = TWO_PI / w;
    int i0 = clamp(int(floor((phi_r + PI) / dphi)), 0, size.x - 1);
    int j0 = clamp(int(floor(theta_r / PI * h)), 0, size.y - 1);
    float a0 = sin(0.5 * (theta_r - row_theta(j0, size.y)));
    float b0 = sin(0.5 * (phi_r - column_phi(i0, size.x)));
    float h0 = a0 * a0 + sin_r * sin(row_theta(j0, size.y)) * b0 * b0;
    float reach = min(1.0, h0 + 20.0 / (2.0 * n));
    float max_dtheta = 2.0 * asin(sqrt(reach));
    int j_lo = max(0, int(floor((theta_r - max_dtheta) / PI * h - 0.5)));
    int j_hi = min(size.y - 1, int(ceil((theta_r + max_dtheta) / PI * h - 0.5)));
    float best = -1e30;
    vec3 sum = vec3(0.0);
    float norm = 0.0;
    for (int j = j_lo; j <= j_hi; ++j) {
        float theta_k = row_theta(j, size.y);
        float sin_k = sin(theta_k);
        float a = sin(0.5 * (theta_r - theta_k));
        float rest = reach - a * a;
        if (rest < 0.0) continue;
        float across = sin_r * sin_k;
        int i_lo = 0;
        int count = size.x;
        if (across > rest) {
            float max_dphi = 2.0 * asin(sqrt(rest / across));
            i_lo = int(floor((phi_r - max_dphi + PI) / dphi - 0.5));
            count = min(size.x, int(ceil((phi_r + max_dphi + PI) / dphi - 0.5)) - i_lo + 1);
        }
        // The row's solid angle dphi (cos(theta_top) - cos(theta_bottom)), as a product.
        float log_omega = log(dphi * 2.0 * sin_k * sin(0.5 * PI / h));
        for (int c = 0; c < count; ++c) {
            int i = i_lo + c;
            if (i < 0) i += size.x;
            if (i >= size.x) i -= size.x;
            float b = sin(0.5 * (phi_r - column_phi(i, size.x)));
            float hk = a * a + across * b * b;
            if (hk > reach || hk >= 0.5) continue;
            float lw = n * log1m(2.0 * hk) + log_omega;
            if (lw > best) {
                float scale = exp(best - lw);
                sum *= scale;
                norm *= scale;
                best = lw;
            }
            float wk = exp(lw - best);
            sum += wk * texelFetch(map, ivec2(i, j), 0).rgb;
            norm += wk;
        }
    }
    return norm > 0.0 ? sum / norm : texelFetch(map, ivec2(i0, j0), 0).rgb;
}
