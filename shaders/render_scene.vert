#version 300 es
// The object in world space (+Y up, -Z forward; docs/conventions.md): positions, normals, baked ao.
layout(location = 0) in vec3 a_position;
layout(location = 1) in vec3 a_normal;
layout(location = 2) in float a_ao;  // baked ambient occlusion; the constant 1 without it or with --no-ao
uniform mat4 u_model;
uniform mat3 u_normal_matrix;  // inverse transpose of u_model's upper 3x3
uniform mat4 u_view_projection;
out vec3 v_normal;
out vec3 v_world;
out float v_ao;
void main() {
    vec4 world = u_model * vec4(a_position, 1.0);
    v_world = world.xyz;
    v_normal = u_normal_matrix * a_normal;
    v_ao = a_ao;
    gl_Position = u_view_projection * world;
}
