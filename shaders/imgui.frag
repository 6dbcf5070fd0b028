#version 300 es
// Dear ImGui's triangles (appliance/ui/imgui_layer.cpp). With the font atlas, a one-channel R8
// texture, the vertex colour times the atlas' coverage (its white rectangle, which untextured
// shapes sample, is 1); with any other texture (an RGBA image the menu shows: a camera preview),
// the vertex colour times the texel. Straight alpha out: the layer blends with SRC_ALPHA,
// ONE_MINUS_SRC_ALPHA.
precision mediump float;
uniform sampler2D u_texture;
uniform bool u_coverage;  // the texture is the font atlas
in vec2 v_uv;
in vec4 v_color;
out vec4 o_color;
void main() {
    vec4 texel = texture(u_texture, v_uv);
    o_color = u_coverage ? vec4(v_color.rgb, v_color.a * texel.r) : v_color * texel;
}
