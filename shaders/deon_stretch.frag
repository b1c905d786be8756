#version 330 core
#pragma vertex_stage "vs/unwrap.vert"
// Stretch texture (seed 000 eq. 27) by rasterising the mesh unwrapped: lib/deon_stretch.glsl.
#include "lib/deon_stretch.glsl"
in vec3 v_position;
in vec3 v_normal;
in vec2 v_uv;
in vec4 v_tangent;
out vec4 f_stretch;
void main() {
    f_stretch = deon_stretch(dFdx(v_position), dFdy(v_position), dFdx(v_uv), dFdy(v_uv));
}
