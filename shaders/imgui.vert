#version 300 es
// Dear ImGui's vertices (ImDrawVert: position in pixels, top-left origin, y down; atlas uv; RGBA8
// colour with straight alpha) to clip space over the whole frame (appliance/ui/imgui_layer.cpp).
layout(location = 0) in vec2 a_position;
layout(location = 1) in vec2 a_uv;
layout(location = 2) in vec4 a_color;
uniform vec2 u_frame_size;  // the framebuffer in pixels
out vec2 v_uv;
out vec4 v_color;
void main() {
    v_uv = a_uv;
    v_color = a_color;
    vec2 ndc = a_position / u_frame_size * 2.0 - 1.0;
    gl_Position = vec4(ndc.x, -ndc.y, 0.0, 1.0);  // ImGui's y grows downwards, GL's upwards
}
