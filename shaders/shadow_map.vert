#version 330 core
// Shadow map (seed 000 §4.1.1): p' = p * M * View * P (eq. 6).
#include "lib/mesh_vs.glsl"
uniform mat4 u_light_matrix;
out float v_depth;
void main() {
    vec4 p = u_light_matrix * vec4(in_position, 1.0);
    gl_Position = p;
    v_depth = p.z / p.w * 0.5 + 0.5;
}
