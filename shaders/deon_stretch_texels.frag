#version 330 core
#pragma vertex_stage "vs/fullscreen.vert"
// Stretch texture (seed 000 eq. 27, lib/deon_stretch.glsl) as one full-screen draw over the texel
// surface map: the unwrap's derivatives are stored there, and its UV advances one texel per pixel.
#include "lib/deon_stretch.glsl"
#include "lib/texel_surface.glsl"
in vec2 v_uv;
out vec4 f_stretch;
void main() {
    TexelSurface s = texel_surface();
    vec2 texel = 1.0 / vec2(textureSize(surface_p, 0));
    f_stretch = deon_stretch(s.dPdx, s.dPdy, vec2(texel.x, 0.0), vec2(0.0, texel.y));
}
