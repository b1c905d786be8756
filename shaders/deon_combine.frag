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
// BLUR_SOURCES (passes/deon.blur_sources, issue 27): 3 bits a slot, the slot whose texture slot k fetches;
// a used slot whose texture an earlier used slot fetched already (blur_0..2 are the irradiance itself at
// the defaults) takes that value instead of fetching it again: the same values added in the same order.
// Times u_one (1.0, a uniform): with the same operand twice the compiler may factor w0 b + w1 b into
// (w0 + w1) b, which rounds differently (seen on llvmpipe); x * 1.0 is exact
uniform float u_one;
#ifndef BLUR_SOURCES
#define BLUR_SOURCES 16434824  // 0o76543210: every slot its own
#endif
// unused slots are bound to a 1x1 dummy (generic shaders): clamp the fetch into it
#define FETCH(k, s) ((((HALF_MASK >> k) & 1) != 0) ? texture(s, (vec2(p) + 0.5) / u_size).rgb : texelFetch(s, min(p, textureSize(s, 0) - 1), 0).rgb)
#define ADD(k) if (((G_MASK >> k) & 1) != 0) acc += u_w[k] * b##k;

void main() {
    ivec2 p = ivec2(gl_FragCoord.xy);
    vec3 acc = vec3(0.0);
    vec3 b0 = FETCH(0, blur0);
#if ((BLUR_SOURCES >> 3) & 7) == 0
    vec3 b1 = b0 * u_one;
#else
    vec3 b1 = FETCH(1, blur1);
#endif
#if ((BLUR_SOURCES >> 6) & 7) == 0
    vec3 b2 = b0 * u_one;
#elif ((BLUR_SOURCES >> 6) & 7) == 1
    vec3 b2 = b1 * u_one;
#else
    vec3 b2 = FETCH(2, blur2);
#endif
#if ((BLUR_SOURCES >> 9) & 7) < 3
    vec3 b3 = (((BLUR_SOURCES >> 9) & 7) == 0 ? b0 : ((BLUR_SOURCES >> 9) & 7) == 1 ? b1 : b2) * u_one;
#else
    vec3 b3 = FETCH(3, blur3);
#endif
    vec3 b4 = FETCH(4, blur4);
    vec3 b5 = FETCH(5, blur5);
    vec3 b6 = FETCH(6, blur6);
    vec3 b7 = FETCH(7, blur7);
    ADD(0) ADD(1) ADD(2) ADD(3) ADD(4) ADD(5) ADD(6) ADD(7)
    if (u_transmitted != 0) acc += texture(transmitted, (vec2(p) + 0.5) / u_size).rgb;
    f_color = vec4(finite3(acc), 1.0);
}
