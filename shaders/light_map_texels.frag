#version 330 core
#pragma vertex_stage "vs/fullscreen.vert"
// Gosselin light map (lib/light_map.glsl) as one full-screen draw over the texel surface map: one
// fragment per texel (issue 14, see deon_irradiance_texels.frag).
#include "lib/light_map.glsl"
#include "lib/texel_surface.glsl"
in vec2 v_uv;
void main() {
    ENV_VIS_IN();
    TexelSurface s = texel_surface();
    light_map(s.P, s.N, v_uv, s.T, s.dPdx, s.dPdy);
}
