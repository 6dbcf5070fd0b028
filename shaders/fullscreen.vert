#version 300 es
// One triangle that covers the viewport; the fragment shaders find their
// texel from gl_FragCoord, and a scissor rectangle restricts a draw to a tile.
void main() {
    vec2 corner = vec2(float((gl_VertexID << 1) & 2), float(gl_VertexID & 2));
    gl_Position = vec4(corner * 2.0 - 1.0, 0.0, 1.0);
}
