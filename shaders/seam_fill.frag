#version 330 core
#pragma vertex_stage "vs/fullscreen.vert"
// The seam fill of a texture-space blur's input, drawn over the output's tiles: lib/seam_fill.glsl
// (shared with seam_fill_cs.comp).
#include "lib/seam_fill.glsl"
out vec4 f_color;
void main() {
    f_color = seam_fill_at(ivec2(gl_FragCoord.xy));
}
