#version 330 core
#pragma vertex_stage "vs/unwrap.vert"
// Irradiance in texture space by rasterising the mesh unwrapped (seed 000 eq. 8, 28, 32):
// lib/deon_irradiance.glsl. deon_irradiance_texels.frag computes the same from the texel surface map.
#include "lib/deon_irradiance.glsl"
in vec3 v_position;
in vec3 v_normal;
in vec2 v_uv;
in vec4 v_tangent;
void main() {
    ENV_VIS_IN();
    deon_irradiance(v_position, v_normal, v_uv, v_tangent, dFdx(v_position), dFdy(v_position));
}
