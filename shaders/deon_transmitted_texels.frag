#version 330 core
#pragma vertex_stage "vs/fullscreen.vert"
// deon_transmitted.frag as one full-screen draw over the texel surface map: one fragment per texel
// (issue 14, see deon_irradiance_texels.frag); it reads only the position map.
#include "lib/deon_transmitted.glsl"
#include "lib/texel_surface.glsl"
in vec2 v_uv;
void main() {
    deon_transmitted(texel_position(), v_uv);
}
