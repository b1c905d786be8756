#version 330 core
#pragma vertex_stage "vs/unwrap.vert"
// Gosselin light map (seed 000 eq. 9-10) by rasterising the mesh unwrapped: lib/light_map.glsl.
#include "lib/light_map.glsl"
in vec3 v_position;
in vec3 v_normal;
in vec2 v_uv;
in vec4 v_tangent;
void main() {
    ENV_VIS_IN();
    light_map(v_position, v_normal, v_uv, v_tangent, dFdx(v_position), dFdy(v_position));
}
