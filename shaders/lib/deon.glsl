// Helpers of the d'Eon & Luebke 2007 passes (seed 000 §4.2).
#ifndef SKINVIEWER_DEON_GLSL
#define SKINVIEWER_DEON_GLSL
#include "lib/color.glsl"
// Light-space distance in mm of the modified TSM (§4.2.7): along the light direction for a
// directional light, from the light position for a point light.
uniform int u_tsm_kind;   // LIGHT_DIRECTIONAL or LIGHT_POINT
uniform vec3 u_tsm_dir;   // towards the light
uniform vec3 u_tsm_pos;
uniform float u_mm_per_unit;
float tsm_distance_mm(vec3 P) {
    float d = (u_tsm_kind == LIGHT_POINT) ? length(P - u_tsm_pos) : -dot(P, u_tsm_dir);
    return d * u_mm_per_unit;
}
#endif
