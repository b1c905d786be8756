#version 330 core
#pragma vertex_stage "vs/fullscreen.vert"
// The light-independent half of the irradiance (issue 27; lib/deon_irradiance.glsl DEON_SURFACE): per
// texel of the texel surface map, the shading normal, C^mix, the specular parameters rho_dt reads and
// the environment's term, which no light move changes; deon_irradiance_texels.frag (DEON_CACHED) reads
// them.
#ifndef DEON_SURFACE
#define DEON_SURFACE 1
#endif
#include "lib/deon_irradiance.glsl"
#include "lib/texel_surface.glsl"
in vec2 v_uv;
void main() {
    ENV_VIS_IN();
    TexelSurface s = texel_surface();
    deon_irradiance_surface(s.N, v_uv, s.T);
}
