// The light transmitted through the body from the TSM light (seed 000 eq. 33, lib/tsm_transmit.glsl)
// at one texel's surface point, for deon_transmitted.frag (mesh unwrapped) and
// deon_transmitted_texels.frag (full-screen over the texel surface map).
#ifndef SKINVIEWER_DEON_TRANSMITTED_GLSL
#define SKINVIEWER_DEON_TRANSMITTED_GLSL
#include "lib/color.glsl"
#include "lib/deon.glsl"
#if defined(GAUSSIAN_MASK) && !defined(GENERIC_SHADERS)
#define G_MASK GAUSSIAN_MASK
#else
#define G_MASK 255
#endif
#define G_TSM 1
#include "lib/deon_blurs.glsl"
#include "lib/tsm_transmit.glsl"
out vec4 f_color;
void deon_transmitted(vec3 P, vec3 N, vec2 uv) {
    f_color = vec4(finite3(tsm_transmitted(P, N, uv)), 1.0);
}
#endif
