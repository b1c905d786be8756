#version 330 core
// Shared vertex stage: the mesh seen by the camera (the view-dependent final passes).
#include "../lib/mesh_vs.glsl"
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
    ENV_VIS_OUT();
    gl_Position = u_view_proj * vec4(in_position, 1.0);
}
