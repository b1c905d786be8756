#version 330 core
#pragma vertex_stage "vs/fullscreen.vert"
// d'Eon's final pass, its light part drawn full-screen (issue 27; lib/deon_final.glsl, FINAL_SCREEN): the
// position, uv and vertex normal of the fragment the view pass kept at this pixel come from its maps, so
// the mesh is not rasterised again (on llvmpipe its ~1 triangle a pixel cost more than the shading).
#ifndef DEON_FINAL_PART
#define DEON_FINAL_PART 2
#endif
#define FINAL_SCREEN 1
#include "lib/deon_final.glsl"
