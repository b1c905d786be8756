#version 330 core
// Shared vertex stage: texture-space unwrap (seed 000 eq. 8), pos.xy = coord_tex * 2 - 1,
// independent of the camera.
#include "../lib/mesh_vs.glsl"
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
    gl_Position = vec4(in_uv * 2.0 - 1.0, 0.0, 1.0);
}
