#version 330 core
#pragma vertex_stage "vs/camera.vert"
// d'Eon's final pass drawn over the mesh (lib/deon_final.glsl): the whole pass, its view part
// (DEON_FINAL_PART = 1) or its light part over the mesh (DEON_FINAL_PART = 2: beam lights, whose footprint
// is the mesh's dFdx); deon_final_light.frag is the light part drawn full-screen.
#include "lib/deon_final.glsl"
