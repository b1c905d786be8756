#version 330 core
// Modified translucent shadow map (seed 000 §4.2.7): rendered like the shadow map (eq. 6).
#include "lib/mesh_vs.glsl"
uniform mat4 u_light_matrix;
out vec3 v_position;
out vec3 v_normal;
out vec2 v_uv;
void main() {
    v_position = in_position;
    v_normal = in_normal;
    v_uv = in_uv;
    gl_Position = u_light_matrix * vec4(in_position, 1.0);
}
