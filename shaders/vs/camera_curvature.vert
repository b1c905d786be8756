#version 330 core
// vs/camera.vert plus the per-vertex curvature (mm^-1) of pre-integrated skin (penner.frag).
#include "../lib/mesh_vs.glsl"
in float in_curvature;
uniform mat4 u_view_proj;
out vec3 v_position;
out vec3 v_normal;
out vec2 v_uv;
out vec4 v_tangent;
out float v_curvature;
void main() {
    v_position = in_position;
    v_normal = in_normal;
    v_uv = in_uv;
    v_tangent = in_tangent;
    ENV_VIS_OUT();
    v_curvature = in_curvature;
    gl_Position = u_view_proj * vec4(in_position, 1.0);
}
