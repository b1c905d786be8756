#version 330 core
// Screen-space lighting (seed 001 §3.1-3.2): the mesh from the camera, with its view-space depth.
#include "lib/mesh_vs.glsl"
uniform mat4 u_view_proj;
uniform mat4 u_view;
uniform float u_mm_per_unit;
out vec3 v_position;
out vec3 v_normal;
out vec2 v_uv;
out vec4 v_tangent;
out float v_depth_mm;
void main() {
    v_position = in_position;
    v_normal = in_normal;
    v_uv = in_uv;
    v_tangent = in_tangent;
    ENV_VIS_OUT();
    v_depth_mm = -(u_view * vec4(in_position, 1.0)).z * u_mm_per_unit;
    gl_Position = u_view_proj * vec4(in_position, 1.0);
}
