#version 330 core
// R: light-space distance of the lit point A in mm; GB: its UV; A: cos(theta) = |N_A . L|, which
// turns the distance m = d(C) - d(A) along the ray into the depth d = m cos(theta) of eq. (33).
#include "lib/deon.glsl"
in vec3 v_position;
in vec3 v_normal;
in vec2 v_uv;
out vec4 f_tsm;
void main() {
    vec3 L = (u_tsm_kind == LIGHT_POINT) ? normalize(u_tsm_pos - v_position) : u_tsm_dir;
    vec3 N = v_normal;
    float nl = length(N) > 1e-12 ? abs(dot(normalize(N), L)) : 1.0;
    f_tsm = vec4(finite_f32(tsm_distance_mm(v_position)), v_uv, clamp(nl, 0.0, 1.0));
}
