#version 330 core
#pragma vertex_stage "vs/fullscreen.vert"
// deon_transmitted.frag as one full-screen draw over the texel surface map: one fragment per texel
// (issue 14, see deon_irradiance_texels.frag); it reads the position and normal maps.
#include "lib/deon_transmitted.glsl"
#include "lib/texel_surface.glsl"
in vec2 v_uv;
void main() {
    TexelSurface t = texel_surface();
    deon_transmitted(t.P, t.N, v_uv);
}
