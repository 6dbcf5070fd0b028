#version 300 es
// The display's frame (with fullscreen.vert): Reinhard's global operator (Reinhard et al. 2002,
// eq. 2 and 4) on the HDR target, then the sRGB transfer curve; pixels the HDR target does not
// cover (alpha 0: no object, no environment background) show the background image, or black.
//   L_s = key / L_avg * L,   L_d = L_s (1 + L_s / L_white^2) / (1 + L_s),   rgb_d = rgb * L_d / L
precision highp float;
uniform highp sampler2D u_hdr;
uniform mediump sampler2D u_image;  // the background image (sRGB-encoded), when u_has_image
uniform bool u_has_image;
uniform vec2 u_size;
uniform float u_scale;      // key / L_avg
uniform float u_white_sq;   // L_white^2, in scaled luminance
out vec4 o_color;

vec3 srgb_encode(vec3 c) {
    c = clamp(c, 0.0, 1.0);
    return mix(12.92 * c, 1.055 * pow(c, vec3(1.0 / 2.4)) - 0.055, step(0.0031308, c));
}

void main() {
    vec4 hdr = texelFetch(u_hdr, ivec2(gl_FragCoord.xy), 0);
    if (hdr.a == 0.0) {
        // The image's rows are top first; the frame's y grows upwards.
        vec2 uv = vec2(gl_FragCoord.x / u_size.x, 1.0 - gl_FragCoord.y / u_size.y);
        o_color = u_has_image ? vec4(texture(u_image, uv).rgb, 1.0) : vec4(0.0, 0.0, 0.0, 1.0);
        return;
    }
    float l = dot(hdr.rgb, vec3(0.2126, 0.7152, 0.0722));
    float ls = u_scale * l;
    float ld = ls * (1.0 + ls / u_white_sq) / (1.0 + ls);
    vec3 rgb = l > 0.0 ? hdr.rgb * (ld / l) : vec3(0.0);
    o_color = vec4(srgb_encode(rgb), 1.0);
}
