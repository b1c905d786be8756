#version 330 core
#pragma vertex_stage "vs/unwrap.vert"
// The light transmitted through the body from the TSM light (seed 000 eq. 33, lib/tsm_transmit.glsl)
// in texture space: it depends on the shaded point, the light and the blurs, not on the camera, so
// it is computed once per light change, added to deon_combine's sum and an orbit does not pay it.
#include "lib/color.glsl"
#include "lib/deon.glsl"
in vec3 v_position;
in vec3 v_normal;
in vec2 v_uv;
in vec4 v_tangent;
out vec4 f_color;
#if defined(GAUSSIAN_MASK) && !defined(GENERIC_SHADERS)
#define G_MASK GAUSSIAN_MASK
#else
#define G_MASK 255
#endif
#define G_TSM 1
#include "lib/deon_blurs.glsl"
#include "lib/tsm_transmit.glsl"
void main() {
    f_color = vec4(finite3(tsm_transmitted(v_position, v_uv)), 1.0);
}
