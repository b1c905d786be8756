#version 330 core
#pragma vertex_stage "vs/fullscreen.vert"
// One direction of d'Eon's separable 7-tap blur in texture space (seed 000 eq. 25-26), drawn over
// the output's tiles; the blur itself is lib/deon_blur.glsl (shared with deon_blur_cs.comp).
#include "lib/deon_blur.glsl"
in vec2 v_uv;
out vec4 f_color;
void main() {
    f_color = deon_blur_at(ivec2(gl_FragCoord.xy));
}
