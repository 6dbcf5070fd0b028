#version 300 es
// A full-screen quad with texture coordinates (the camera image behind the scene). The image's
// rows are top first (an upload of a picture) unless u_flip (a frame GL rendered: bottom first).
uniform bool u_flip;
out vec2 v_uv;
void main() {
    vec2 corner = vec2(float((gl_VertexID << 1) & 2), float(gl_VertexID & 2));
    v_uv = vec2(corner.x, u_flip ? corner.y : 1.0 - corner.y);
    gl_Position = vec4(corner * 2.0 - 1.0, 0.0, 1.0);
}
