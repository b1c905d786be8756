#version 330 core
#pragma vertex_stage "vs/fullscreen.vert"
// Irradiance in texture space (lib/deon_irradiance.glsl) as one full-screen draw over the texel
// surface map: one fragment per texel. Rasterising the mesh unwrapped instead shades every small
// triangle's own pixel blocks, on a SIMD rasteriser many times the texels it covers (issue 14).
// The inputs are the same interpolated values; v_uv is the texel centre.
#include "lib/deon_irradiance.glsl"
#include "lib/texel_surface.glsl"
in vec2 v_uv;
void main() {
    ENV_VIS_IN();
    TexelSurface s = texel_surface();
    deon_irradiance(s.P, s.N, v_uv, s.T, s.dPdx, s.dPdy);
}
