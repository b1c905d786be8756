#version 330 core
// Phong/Lambert baseline: the naive reference every skin technique is compared against.
#include "lib/mesh_vs.glsl"
uniform mat4 u_view_proj;
out vec3 v_position;
out vec3 v_normal;
out vec2 v_uv;
out vec4 v_tangent;
void main() {
    v_position = in_position;
    v_normal = in_normal;
    v_uv = in_uv;
    v_tangent = in_tangent;
    gl_Position = u_view_proj * vec4(in_position, 1.0);
}
