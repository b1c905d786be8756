#version 330 core
#pragma vertex_stage "vs/fullscreen.vert"
// The diffuse sum of seed 000 eq. 34, sum_i w_i blur_i, in texture space (issue 14): it depends on
// the blurs and the weights only, so a camera move does not re-run it and deon_final reads one
// texture instead of one per Gaussian. Bilinear filtering is linear: sampling this sum equals the
// sum of the samples up to float rounding. Specialised by GAUSSIAN_MASK (bit i: Gaussian i used).
// The light transmitted through thin parts (eq. 33), view-independent too, is added here.
#include "lib/color.glsl"
uniform vec3 u_w[MAX_GAUSSIANS];
uniform sampler2D blur0;
uniform sampler2D blur1;
uniform sampler2D blur2;
uniform sampler2D blur3;
uniform sampler2D blur4;
uniform sampler2D blur5;
uniform sampler2D blur6;
uniform sampler2D blur7;
uniform sampler2D transmitted;  // deon_transmitted (eq. 33) when the TSM runs
uniform int u_transmitted;
uniform vec2 u_size;            // this map's size (the transmitted map is half of it)
out vec4 f_color;

#if defined(GAUSSIAN_MASK) && !defined(GENERIC_SHADERS)
#define G_MASK GAUSSIAN_MASK
#else
#define G_MASK 255
#endif
// HALF_MASK bit i: blur i is half this map's size (deon.half_res_above_texels): filtered up at the texel centre
#ifndef HALF_MASK
#define HALF_MASK 0
#endif
// unused slots are bound to a 1x1 dummy (generic shaders): clamp the fetch into it
#define ADD(k, s) if (((G_MASK >> k) & 1) != 0) acc += u_w[k] * ((((HALF_MASK >> k) & 1) != 0) ? texture(s, (vec2(p) + 0.5) / u_size).rgb : texelFetch(s, min(p, textureSize(s, 0) - 1), 0).rgb);

void main() {
    ivec2 p = ivec2(gl_FragCoord.xy);
    vec3 acc = vec3(0.0);
    ADD(0, blur0) ADD(1, blur1) ADD(2, blur2) ADD(3, blur3)
    ADD(4, blur4) ADD(5, blur5) ADD(6, blur6) ADD(7, blur7)
    if (u_transmitted != 0) acc += texture(transmitted, (vec2(p) + 0.5) / u_size).rgb;
    f_color = vec4(finite3(acc), 1.0);
}
