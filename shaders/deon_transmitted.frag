#version 330 core
#pragma vertex_stage "vs/unwrap.vert"
// The light transmitted through the body from the TSM light (seed 000 eq. 33, lib/deon_transmitted.glsl)
// in texture space: it depends on the shaded point, the light and the blurs, not on the camera, so
// it is computed once per light change, added to deon_combine's sum and an orbit does not pay it.
#include "lib/deon_transmitted.glsl"
in vec3 v_position;
in vec3 v_normal;
in vec2 v_uv;
in vec4 v_tangent;
void main() {
    deon_transmitted(v_position, v_normal, v_uv);
}
