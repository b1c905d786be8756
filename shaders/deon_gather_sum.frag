#version 330 core
#pragma vertex_stage "vs/fullscreen.vert"
// The summed step's light-dependent half (issue 27; physics/surface_gather.gather_sum, its twin): the sum
// of deon_surface_gather.frag (seed 000 eq. 21 with 3D distances) from the weights deon_gather_weights.frag
// made once (kept by the graph across light moves):
//   out(x) = (sum_inner W_y E(y) + sum_blocks [G_lit(x) E_b A_b / s, W_b A-bar_b]) / sum W
// E past a mesh border (W < 0) at PAST_BORDER_SHARE of its light; each block's light Gaussian taken at the
// light's own mean point (its spread added), as deon_surface_gather.frag does: that needs the light, so it
// stays here (one exp a block). Computed at the island texel the gutter map names (the weights at the
// fragment are the ones made for that texel), so gutters come out dilated.
// One line per tap, its weight's index a literal (a loop left rolled by the compiler would index the
// weights dynamically): the 36 inner texels row by row, then the blocks ring by ring
// (physics/surface_gather.block_offsets).
#include "lib/color.glsl"
#include "lib/gather_surface.glsl"
#ifndef GATHER_BLOCKS
#define GATHER_BLOCKS 3
#endif
#ifndef WEIGHT_TEXTURES
#define WEIGHT_TEXTURES 19
#endif
#ifndef LIT_RING
#define LIT_RING GATHER_BLOCKS  // the rings whose light is taken at its own mean point (the rest: FLAT)
#endif
#ifndef KEPT_RINGS
#define KEPT_RINGS 3  // the rings whose weights are kept (physics/surface_gather.KEPT_RINGS); the rest: LIVE
#endif
uniform sampler2D source;     // the blur's input, seam-filled
uniform sampler2D surface;    // deon_gather_surface.frag: xyz mm, w area mm^2
uniform sampler2D gutter;     // RG nearest island texel
uniform sampler2D blocks_e;   // deon_gather_blocks.frag MEAN_THICKNESS: RGB sum E A, A the mean thickness
uniform sampler2D blocks_l;   // xyz the light's mean point, w its spread
uniform sampler2D blocks_m;   // (LIT_RING < GATHER_BLOCKS) RGB the mean light sum E A / sum A, A the mean thickness
uniform float u_var;          // variance added, mm^2
#if GATHER_BLOCKS > KEPT_RINGS  // the rings past KEPT_RINGS: their weights computed here, as deon_gather_weights.frag does
uniform sampler2D blocks_p;   // (BLOCK_SURFACE) xyz mean point (mm), w area
uniform sampler2D blocks_z;   // R zone, G spread (mm^2 per axis)
uniform sampler2D stretch_map;  // RG UV per mm, B shear cosine
uniform int u_use_stretch;
uniform vec2 u_uniform_stretch;
uniform float u_shortcut;     // SHORTCUT_RATIO (passes/deon.py)

float sheet(vec3 d, vec2 o, float c) {  // deon_surface_gather.frag's sheet test
    return (dot(d, d) < u_shortcut * u_shortcut * (dot(o, o) + 2.0 * c * o.x * o.y)) ? 0.0 : 1.0;
}
#endif
#if WEIGHT_TEXTURES > 0
uniform sampler2D w0;
#endif
#if WEIGHT_TEXTURES > 1
uniform sampler2D w1;
#endif
#if WEIGHT_TEXTURES > 2
uniform sampler2D w2;
#endif
#if WEIGHT_TEXTURES > 3
uniform sampler2D w3;
#endif
#if WEIGHT_TEXTURES > 4
uniform sampler2D w4;
#endif
#if WEIGHT_TEXTURES > 5
uniform sampler2D w5;
#endif
#if WEIGHT_TEXTURES > 6
uniform sampler2D w6;
#endif
#if WEIGHT_TEXTURES > 7
uniform sampler2D w7;
#endif
#if WEIGHT_TEXTURES > 8
uniform sampler2D w8;
#endif
#if WEIGHT_TEXTURES > 9
uniform sampler2D w9;
#endif
#if WEIGHT_TEXTURES > 10
uniform sampler2D w10;
#endif
#if WEIGHT_TEXTURES > 11
uniform sampler2D w11;
#endif
#if WEIGHT_TEXTURES > 12
uniform sampler2D w12;
#endif
#if WEIGHT_TEXTURES > 13
uniform sampler2D w13;
#endif
#if WEIGHT_TEXTURES > 14
uniform sampler2D w14;
#endif
#if WEIGHT_TEXTURES > 15
uniform sampler2D w15;
#endif
#if WEIGHT_TEXTURES > 16
uniform sampler2D w16;
#endif
#if WEIGHT_TEXTURES > 17
uniform sampler2D w17;
#endif
#if WEIGHT_TEXTURES > 18
uniform sampler2D w18;
#endif
#if WEIGHT_TEXTURES > 19
uniform sampler2D w19;
#endif
#if WEIGHT_TEXTURES > 20
uniform sampler2D w20;
#endif
#if WEIGHT_TEXTURES > 21
uniform sampler2D w21;
#endif
#if WEIGHT_TEXTURES > 22
uniform sampler2D w22;
#endif
#if WEIGHT_TEXTURES > 23
uniform sampler2D w23;
#endif
#if WEIGHT_TEXTURES > 24
uniform sampler2D w24;
#endif
#if WEIGHT_TEXTURES > 25
uniform sampler2D w25;
#endif
#if WEIGHT_TEXTURES > 26
uniform sampler2D w26;
#endif
#if WEIGHT_TEXTURES > 27
uniform sampler2D w27;
#endif
out vec4 f_color;

// inner texel (I, J) of x's 6 x 6 (from 2 b), weight K: |W| E, its light shared past a border (W < 0)
#define INNER(I, J, K) { float w = W[(K) >> 2][(K) & 3]; vec4 e = texelFetch(source, clamp(b2 + ivec2(I, J), ivec2(0), hi), 0); float a = abs(w); acc += a * vec4((w > 0.0) ? e.rgb : PAST_BORDER_SHARE * e.rgb, e.a); wsum += a; }
// block (I, J) from b, weight K = w A_b / s (-1: not summed): its thickness at W, its light at its own mean point
#define BLOCK(I, J, K) { float w = W[(K) >> 2][(K) & 3]; ivec2 c = clamp(b + ivec2(I, J), ivec2(0), bhi); vec4 e = texelFetch(blocks_e, c, 0); float a = max(w, 0.0); acc.a += a * e.a; wsum += a; vec4 l = texelFetch(blocks_l, c, 0); vec3 dl = l.xyz - x; float vl = var + l.w; lit += ((w >= 0.0) ? (var / vl) * exp(-0.5 * dot(dl, dl) / vl) : 0.0) * e.rgb; }
// a block past LIT_RING: its light at its area's mean point (the weight of its thickness), one fetch, no exp
#define FLAT(I, J, K) { float a = max(W[(K) >> 2][(K) & 3], 0.0); acc += a * texelFetch(blocks_m, clamp(b + ivec2(I, J), ivec2(0), bhi), 0); wsum += a; }
// a block past KEPT_RINGS: its weight w A_b / s computed here (deon_gather_weights.frag's BLOCK), then as
// BLOCK (LITP 1: its light at its own mean point) or FLAT (LITP 0)
#define LIVE(I, J, LITP) { ivec2 c = b + ivec2(I, J); float inside = (all(greaterThanEqual(c, ivec2(0))) && all(lessThanEqual(c, bhi))) ? 1.0 : 0.0; c = clamp(c, ivec2(0), bhi); vec4 q = texelFetch(blocks_p, c, 0); vec2 z = texelFetch(blocks_z, c, 0).rg; vec3 d = q.xyz - x; float same = inside * ((abs(z.r - zone) < 0.5 && q.w > 0.0) ? 1.0 : 0.0) * sheet(d, (vec2(2 * c - src) + 0.5) * mm_per_texel, cs); float vb = var + z.g; float a = same * min((var / vb) * exp(-0.5 * dot(d, d) / vb) * q.w / s, 65504.0); if (LITP > 0.5) { vec4 e = texelFetch(blocks_e, c, 0); acc.a += a * e.a; vec4 l = texelFetch(blocks_l, c, 0); vec3 dl = l.xyz - x; float vl = var + l.w; lit += same * (var / vl) * exp(-0.5 * dot(dl, dl) / vl) * e.rgb; } else { acc += a * texelFetch(blocks_m, c, 0); } wsum += a; }

void main() {
    ivec2 p = ivec2(gl_FragCoord.xy);
    ivec2 src = ivec2(texelFetch(gutter, p, 0).rg + 0.5);
    vec4 xs = texelFetch(surface, src, 0);
    vec3 x = xs.xyz;
    float s = (abs(xs.w) > 0.0) ? abs(xs.w) : 1.0;
    float var = max(u_var, 1e-30);
    vec4 W[WEIGHT_TEXTURES];
#if WEIGHT_TEXTURES > 0
    W[0] = texelFetch(w0, p, 0);
#endif
#if WEIGHT_TEXTURES > 1
    W[1] = texelFetch(w1, p, 0);
#endif
#if WEIGHT_TEXTURES > 2
    W[2] = texelFetch(w2, p, 0);
#endif
#if WEIGHT_TEXTURES > 3
    W[3] = texelFetch(w3, p, 0);
#endif
#if WEIGHT_TEXTURES > 4
    W[4] = texelFetch(w4, p, 0);
#endif
#if WEIGHT_TEXTURES > 5
    W[5] = texelFetch(w5, p, 0);
#endif
#if WEIGHT_TEXTURES > 6
    W[6] = texelFetch(w6, p, 0);
#endif
#if WEIGHT_TEXTURES > 7
    W[7] = texelFetch(w7, p, 0);
#endif
#if WEIGHT_TEXTURES > 8
    W[8] = texelFetch(w8, p, 0);
#endif
#if WEIGHT_TEXTURES > 9
    W[9] = texelFetch(w9, p, 0);
#endif
#if WEIGHT_TEXTURES > 10
    W[10] = texelFetch(w10, p, 0);
#endif
#if WEIGHT_TEXTURES > 11
    W[11] = texelFetch(w11, p, 0);
#endif
#if WEIGHT_TEXTURES > 12
    W[12] = texelFetch(w12, p, 0);
#endif
#if WEIGHT_TEXTURES > 13
    W[13] = texelFetch(w13, p, 0);
#endif
#if WEIGHT_TEXTURES > 14
    W[14] = texelFetch(w14, p, 0);
#endif
#if WEIGHT_TEXTURES > 15
    W[15] = texelFetch(w15, p, 0);
#endif
#if WEIGHT_TEXTURES > 16
    W[16] = texelFetch(w16, p, 0);
#endif
#if WEIGHT_TEXTURES > 17
    W[17] = texelFetch(w17, p, 0);
#endif
#if WEIGHT_TEXTURES > 18
    W[18] = texelFetch(w18, p, 0);
#endif
#if WEIGHT_TEXTURES > 19
    W[19] = texelFetch(w19, p, 0);
#endif
#if WEIGHT_TEXTURES > 20
    W[20] = texelFetch(w20, p, 0);
#endif
#if WEIGHT_TEXTURES > 21
    W[21] = texelFetch(w21, p, 0);
#endif
#if WEIGHT_TEXTURES > 22
    W[22] = texelFetch(w22, p, 0);
#endif
#if WEIGHT_TEXTURES > 23
    W[23] = texelFetch(w23, p, 0);
#endif
#if WEIGHT_TEXTURES > 24
    W[24] = texelFetch(w24, p, 0);
#endif
#if WEIGHT_TEXTURES > 25
    W[25] = texelFetch(w25, p, 0);
#endif
#if WEIGHT_TEXTURES > 26
    W[26] = texelFetch(w26, p, 0);
#endif
#if WEIGHT_TEXTURES > 27
    W[27] = texelFetch(w27, p, 0);
#endif
    ivec2 hi = textureSize(source, 0) - 1;
    ivec2 bhi = textureSize(blocks_e, 0) - 1;
    ivec2 b = src >> 1;
    ivec2 b2 = 2 * b;
    vec4 acc = vec4(0.0);
    float wsum = 0.0;
    vec3 lit = vec3(0.0);
#if GATHER_BLOCKS > KEPT_RINGS
    float zone = abs(texelFetch(gutter, src, 0).b);
    vec3 st = (u_use_stretch != 0) ? texelFetch(stretch_map, src, 0).rgb : vec3(u_uniform_stretch, 0.0);
    vec2 mm_per_texel = 1.0 / max(st.rg * vec2(textureSize(source, 0)), vec2(1e-30));
    float cs = clamp(st.b, -0.95, 0.95);
#endif
    INNER(-2, -2, 0)
    INNER(-1, -2, 1)
    INNER(0, -2, 2)
    INNER(1, -2, 3)
    INNER(2, -2, 4)
    INNER(3, -2, 5)
    INNER(-2, -1, 6)
    INNER(-1, -1, 7)
    INNER(0, -1, 8)
    INNER(1, -1, 9)
    INNER(2, -1, 10)
    INNER(3, -1, 11)
    INNER(-2, 0, 12)
    INNER(-1, 0, 13)
    INNER(0, 0, 14)
    INNER(1, 0, 15)
    INNER(2, 0, 16)
    INNER(3, 0, 17)
    INNER(-2, 1, 18)
    INNER(-1, 1, 19)
    INNER(0, 1, 20)
    INNER(1, 1, 21)
    INNER(2, 1, 22)
    INNER(3, 1, 23)
    INNER(-2, 2, 24)
    INNER(-1, 2, 25)
    INNER(0, 2, 26)
    INNER(1, 2, 27)
    INNER(2, 2, 28)
    INNER(3, 2, 29)
    INNER(-2, 3, 30)
    INNER(-1, 3, 31)
    INNER(0, 3, 32)
    INNER(1, 3, 33)
    INNER(2, 3, 34)
    INNER(3, 3, 35)
#if GATHER_BLOCKS >= 2
#if KEPT_RINGS >= 2
#if LIT_RING >= 2
    BLOCK(-2, -2, 36)
    BLOCK(-1, -2, 37)
    BLOCK(0, -2, 38)
    BLOCK(1, -2, 39)
    BLOCK(2, -2, 40)
    BLOCK(-2, -1, 41)
    BLOCK(2, -1, 42)
    BLOCK(-2, 0, 43)
    BLOCK(2, 0, 44)
    BLOCK(-2, 1, 45)
    BLOCK(2, 1, 46)
    BLOCK(-2, 2, 47)
    BLOCK(-1, 2, 48)
    BLOCK(0, 2, 49)
    BLOCK(1, 2, 50)
    BLOCK(2, 2, 51)
#else
    FLAT(-2, -2, 36)
    FLAT(-1, -2, 37)
    FLAT(0, -2, 38)
    FLAT(1, -2, 39)
    FLAT(2, -2, 40)
    FLAT(-2, -1, 41)
    FLAT(2, -1, 42)
    FLAT(-2, 0, 43)
    FLAT(2, 0, 44)
    FLAT(-2, 1, 45)
    FLAT(2, 1, 46)
    FLAT(-2, 2, 47)
    FLAT(-1, 2, 48)
    FLAT(0, 2, 49)
    FLAT(1, 2, 50)
    FLAT(2, 2, 51)
#endif
#elif LIT_RING >= 2
    LIVE(-2, -2, 1.0)
    LIVE(-1, -2, 1.0)
    LIVE(0, -2, 1.0)
    LIVE(1, -2, 1.0)
    LIVE(2, -2, 1.0)
    LIVE(-2, -1, 1.0)
    LIVE(2, -1, 1.0)
    LIVE(-2, 0, 1.0)
    LIVE(2, 0, 1.0)
    LIVE(-2, 1, 1.0)
    LIVE(2, 1, 1.0)
    LIVE(-2, 2, 1.0)
    LIVE(-1, 2, 1.0)
    LIVE(0, 2, 1.0)
    LIVE(1, 2, 1.0)
    LIVE(2, 2, 1.0)
#else
    LIVE(-2, -2, 0.0)
    LIVE(-1, -2, 0.0)
    LIVE(0, -2, 0.0)
    LIVE(1, -2, 0.0)
    LIVE(2, -2, 0.0)
    LIVE(-2, -1, 0.0)
    LIVE(2, -1, 0.0)
    LIVE(-2, 0, 0.0)
    LIVE(2, 0, 0.0)
    LIVE(-2, 1, 0.0)
    LIVE(2, 1, 0.0)
    LIVE(-2, 2, 0.0)
    LIVE(-1, 2, 0.0)
    LIVE(0, 2, 0.0)
    LIVE(1, 2, 0.0)
    LIVE(2, 2, 0.0)
#endif
#endif
#if GATHER_BLOCKS >= 3
#if KEPT_RINGS >= 3
#if LIT_RING >= 3
    BLOCK(-3, -3, 52)
    BLOCK(-2, -3, 53)
    BLOCK(-1, -3, 54)
    BLOCK(0, -3, 55)
    BLOCK(1, -3, 56)
    BLOCK(2, -3, 57)
    BLOCK(3, -3, 58)
    BLOCK(-3, -2, 59)
    BLOCK(3, -2, 60)
    BLOCK(-3, -1, 61)
    BLOCK(3, -1, 62)
    BLOCK(-3, 0, 63)
    BLOCK(3, 0, 64)
    BLOCK(-3, 1, 65)
    BLOCK(3, 1, 66)
    BLOCK(-3, 2, 67)
    BLOCK(3, 2, 68)
    BLOCK(-3, 3, 69)
    BLOCK(-2, 3, 70)
    BLOCK(-1, 3, 71)
    BLOCK(0, 3, 72)
    BLOCK(1, 3, 73)
    BLOCK(2, 3, 74)
    BLOCK(3, 3, 75)
#else
    FLAT(-3, -3, 52)
    FLAT(-2, -3, 53)
    FLAT(-1, -3, 54)
    FLAT(0, -3, 55)
    FLAT(1, -3, 56)
    FLAT(2, -3, 57)
    FLAT(3, -3, 58)
    FLAT(-3, -2, 59)
    FLAT(3, -2, 60)
    FLAT(-3, -1, 61)
    FLAT(3, -1, 62)
    FLAT(-3, 0, 63)
    FLAT(3, 0, 64)
    FLAT(-3, 1, 65)
    FLAT(3, 1, 66)
    FLAT(-3, 2, 67)
    FLAT(3, 2, 68)
    FLAT(-3, 3, 69)
    FLAT(-2, 3, 70)
    FLAT(-1, 3, 71)
    FLAT(0, 3, 72)
    FLAT(1, 3, 73)
    FLAT(2, 3, 74)
    FLAT(3, 3, 75)
#endif
#elif LIT_RING >= 3
    LIVE(-3, -3, 1.0)
    LIVE(-2, -3, 1.0)
    LIVE(-1, -3, 1.0)
    LIVE(0, -3, 1.0)
    LIVE(1, -3, 1.0)
    LIVE(2, -3, 1.0)
    LIVE(3, -3, 1.0)
    LIVE(-3, -2, 1.0)
    LIVE(3, -2, 1.0)
    LIVE(-3, -1, 1.0)
    LIVE(3, -1, 1.0)
    LIVE(-3, 0, 1.0)
    LIVE(3, 0, 1.0)
    LIVE(-3, 1, 1.0)
    LIVE(3, 1, 1.0)
    LIVE(-3, 2, 1.0)
    LIVE(3, 2, 1.0)
    LIVE(-3, 3, 1.0)
    LIVE(-2, 3, 1.0)
    LIVE(-1, 3, 1.0)
    LIVE(0, 3, 1.0)
    LIVE(1, 3, 1.0)
    LIVE(2, 3, 1.0)
    LIVE(3, 3, 1.0)
#else
    LIVE(-3, -3, 0.0)
    LIVE(-2, -3, 0.0)
    LIVE(-1, -3, 0.0)
    LIVE(0, -3, 0.0)
    LIVE(1, -3, 0.0)
    LIVE(2, -3, 0.0)
    LIVE(3, -3, 0.0)
    LIVE(-3, -2, 0.0)
    LIVE(3, -2, 0.0)
    LIVE(-3, -1, 0.0)
    LIVE(3, -1, 0.0)
    LIVE(-3, 0, 0.0)
    LIVE(3, 0, 0.0)
    LIVE(-3, 1, 0.0)
    LIVE(3, 1, 0.0)
    LIVE(-3, 2, 0.0)
    LIVE(3, 2, 0.0)
    LIVE(-3, 3, 0.0)
    LIVE(-2, 3, 0.0)
    LIVE(-1, 3, 0.0)
    LIVE(0, 3, 0.0)
    LIVE(1, 3, 0.0)
    LIVE(2, 3, 0.0)
    LIVE(3, 3, 0.0)
#endif
#endif
#if GATHER_BLOCKS >= 4
#if KEPT_RINGS >= 4
#if LIT_RING >= 4
    BLOCK(-4, -4, 76)
    BLOCK(-3, -4, 77)
    BLOCK(-2, -4, 78)
    BLOCK(-1, -4, 79)
    BLOCK(0, -4, 80)
    BLOCK(1, -4, 81)
    BLOCK(2, -4, 82)
    BLOCK(3, -4, 83)
    BLOCK(4, -4, 84)
    BLOCK(-4, -3, 85)
    BLOCK(4, -3, 86)
    BLOCK(-4, -2, 87)
    BLOCK(4, -2, 88)
    BLOCK(-4, -1, 89)
    BLOCK(4, -1, 90)
    BLOCK(-4, 0, 91)
    BLOCK(4, 0, 92)
    BLOCK(-4, 1, 93)
    BLOCK(4, 1, 94)
    BLOCK(-4, 2, 95)
    BLOCK(4, 2, 96)
    BLOCK(-4, 3, 97)
    BLOCK(4, 3, 98)
    BLOCK(-4, 4, 99)
    BLOCK(-3, 4, 100)
    BLOCK(-2, 4, 101)
    BLOCK(-1, 4, 102)
    BLOCK(0, 4, 103)
    BLOCK(1, 4, 104)
    BLOCK(2, 4, 105)
    BLOCK(3, 4, 106)
    BLOCK(4, 4, 107)
#else
    FLAT(-4, -4, 76)
    FLAT(-3, -4, 77)
    FLAT(-2, -4, 78)
    FLAT(-1, -4, 79)
    FLAT(0, -4, 80)
    FLAT(1, -4, 81)
    FLAT(2, -4, 82)
    FLAT(3, -4, 83)
    FLAT(4, -4, 84)
    FLAT(-4, -3, 85)
    FLAT(4, -3, 86)
    FLAT(-4, -2, 87)
    FLAT(4, -2, 88)
    FLAT(-4, -1, 89)
    FLAT(4, -1, 90)
    FLAT(-4, 0, 91)
    FLAT(4, 0, 92)
    FLAT(-4, 1, 93)
    FLAT(4, 1, 94)
    FLAT(-4, 2, 95)
    FLAT(4, 2, 96)
    FLAT(-4, 3, 97)
    FLAT(4, 3, 98)
    FLAT(-4, 4, 99)
    FLAT(-3, 4, 100)
    FLAT(-2, 4, 101)
    FLAT(-1, 4, 102)
    FLAT(0, 4, 103)
    FLAT(1, 4, 104)
    FLAT(2, 4, 105)
    FLAT(3, 4, 106)
    FLAT(4, 4, 107)
#endif
#elif LIT_RING >= 4
    LIVE(-4, -4, 1.0)
    LIVE(-3, -4, 1.0)
    LIVE(-2, -4, 1.0)
    LIVE(-1, -4, 1.0)
    LIVE(0, -4, 1.0)
    LIVE(1, -4, 1.0)
    LIVE(2, -4, 1.0)
    LIVE(3, -4, 1.0)
    LIVE(4, -4, 1.0)
    LIVE(-4, -3, 1.0)
    LIVE(4, -3, 1.0)
    LIVE(-4, -2, 1.0)
    LIVE(4, -2, 1.0)
    LIVE(-4, -1, 1.0)
    LIVE(4, -1, 1.0)
    LIVE(-4, 0, 1.0)
    LIVE(4, 0, 1.0)
    LIVE(-4, 1, 1.0)
    LIVE(4, 1, 1.0)
    LIVE(-4, 2, 1.0)
    LIVE(4, 2, 1.0)
    LIVE(-4, 3, 1.0)
    LIVE(4, 3, 1.0)
    LIVE(-4, 4, 1.0)
    LIVE(-3, 4, 1.0)
    LIVE(-2, 4, 1.0)
    LIVE(-1, 4, 1.0)
    LIVE(0, 4, 1.0)
    LIVE(1, 4, 1.0)
    LIVE(2, 4, 1.0)
    LIVE(3, 4, 1.0)
    LIVE(4, 4, 1.0)
#else
    LIVE(-4, -4, 0.0)
    LIVE(-3, -4, 0.0)
    LIVE(-2, -4, 0.0)
    LIVE(-1, -4, 0.0)
    LIVE(0, -4, 0.0)
    LIVE(1, -4, 0.0)
    LIVE(2, -4, 0.0)
    LIVE(3, -4, 0.0)
    LIVE(4, -4, 0.0)
    LIVE(-4, -3, 0.0)
    LIVE(4, -3, 0.0)
    LIVE(-4, -2, 0.0)
    LIVE(4, -2, 0.0)
    LIVE(-4, -1, 0.0)
    LIVE(4, -1, 0.0)
    LIVE(-4, 0, 0.0)
    LIVE(4, 0, 0.0)
    LIVE(-4, 1, 0.0)
    LIVE(4, 1, 0.0)
    LIVE(-4, 2, 0.0)
    LIVE(4, 2, 0.0)
    LIVE(-4, 3, 0.0)
    LIVE(4, 3, 0.0)
    LIVE(-4, 4, 0.0)
    LIVE(-3, 4, 0.0)
    LIVE(-2, 4, 0.0)
    LIVE(-1, 4, 0.0)
    LIVE(0, 4, 0.0)
    LIVE(1, 4, 0.0)
    LIVE(2, 4, 0.0)
    LIVE(3, 4, 0.0)
    LIVE(4, 4, 0.0)
#endif
#endif
#if GATHER_BLOCKS >= 5
#if KEPT_RINGS >= 5
#if LIT_RING >= 5
    BLOCK(-5, -5, 108)
    BLOCK(-4, -5, 109)
    BLOCK(-3, -5, 110)
    BLOCK(-2, -5, 111)
    BLOCK(-1, -5, 112)
    BLOCK(0, -5, 113)
    BLOCK(1, -5, 114)
    BLOCK(2, -5, 115)
    BLOCK(3, -5, 116)
    BLOCK(4, -5, 117)
    BLOCK(5, -5, 118)
    BLOCK(-5, -4, 119)
    BLOCK(5, -4, 120)
    BLOCK(-5, -3, 121)
    BLOCK(5, -3, 122)
    BLOCK(-5, -2, 123)
    BLOCK(5, -2, 124)
    BLOCK(-5, -1, 125)
    BLOCK(5, -1, 126)
    BLOCK(-5, 0, 127)
    BLOCK(5, 0, 128)
    BLOCK(-5, 1, 129)
    BLOCK(5, 1, 130)
    BLOCK(-5, 2, 131)
    BLOCK(5, 2, 132)
    BLOCK(-5, 3, 133)
    BLOCK(5, 3, 134)
    BLOCK(-5, 4, 135)
    BLOCK(5, 4, 136)
    BLOCK(-5, 5, 137)
    BLOCK(-4, 5, 138)
    BLOCK(-3, 5, 139)
    BLOCK(-2, 5, 140)
    BLOCK(-1, 5, 141)
    BLOCK(0, 5, 142)
    BLOCK(1, 5, 143)
    BLOCK(2, 5, 144)
    BLOCK(3, 5, 145)
    BLOCK(4, 5, 146)
    BLOCK(5, 5, 147)
#else
    FLAT(-5, -5, 108)
    FLAT(-4, -5, 109)
    FLAT(-3, -5, 110)
    FLAT(-2, -5, 111)
    FLAT(-1, -5, 112)
    FLAT(0, -5, 113)
    FLAT(1, -5, 114)
    FLAT(2, -5, 115)
    FLAT(3, -5, 116)
    FLAT(4, -5, 117)
    FLAT(5, -5, 118)
    FLAT(-5, -4, 119)
    FLAT(5, -4, 120)
    FLAT(-5, -3, 121)
    FLAT(5, -3, 122)
    FLAT(-5, -2, 123)
    FLAT(5, -2, 124)
    FLAT(-5, -1, 125)
    FLAT(5, -1, 126)
    FLAT(-5, 0, 127)
    FLAT(5, 0, 128)
    FLAT(-5, 1, 129)
    FLAT(5, 1, 130)
    FLAT(-5, 2, 131)
    FLAT(5, 2, 132)
    FLAT(-5, 3, 133)
    FLAT(5, 3, 134)
    FLAT(-5, 4, 135)
    FLAT(5, 4, 136)
    FLAT(-5, 5, 137)
    FLAT(-4, 5, 138)
    FLAT(-3, 5, 139)
    FLAT(-2, 5, 140)
    FLAT(-1, 5, 141)
    FLAT(0, 5, 142)
    FLAT(1, 5, 143)
    FLAT(2, 5, 144)
    FLAT(3, 5, 145)
    FLAT(4, 5, 146)
    FLAT(5, 5, 147)
#endif
#elif LIT_RING >= 5
    LIVE(-5, -5, 1.0)
    LIVE(-4, -5, 1.0)
    LIVE(-3, -5, 1.0)
    LIVE(-2, -5, 1.0)
    LIVE(-1, -5, 1.0)
    LIVE(0, -5, 1.0)
    LIVE(1, -5, 1.0)
    LIVE(2, -5, 1.0)
    LIVE(3, -5, 1.0)
    LIVE(4, -5, 1.0)
    LIVE(5, -5, 1.0)
    LIVE(-5, -4, 1.0)
    LIVE(5, -4, 1.0)
    LIVE(-5, -3, 1.0)
    LIVE(5, -3, 1.0)
    LIVE(-5, -2, 1.0)
    LIVE(5, -2, 1.0)
    LIVE(-5, -1, 1.0)
    LIVE(5, -1, 1.0)
    LIVE(-5, 0, 1.0)
    LIVE(5, 0, 1.0)
    LIVE(-5, 1, 1.0)
    LIVE(5, 1, 1.0)
    LIVE(-5, 2, 1.0)
    LIVE(5, 2, 1.0)
    LIVE(-5, 3, 1.0)
    LIVE(5, 3, 1.0)
    LIVE(-5, 4, 1.0)
    LIVE(5, 4, 1.0)
    LIVE(-5, 5, 1.0)
    LIVE(-4, 5, 1.0)
    LIVE(-3, 5, 1.0)
    LIVE(-2, 5, 1.0)
    LIVE(-1, 5, 1.0)
    LIVE(0, 5, 1.0)
    LIVE(1, 5, 1.0)
    LIVE(2, 5, 1.0)
    LIVE(3, 5, 1.0)
    LIVE(4, 5, 1.0)
    LIVE(5, 5, 1.0)
#else
    LIVE(-5, -5, 0.0)
    LIVE(-4, -5, 0.0)
    LIVE(-3, -5, 0.0)
    LIVE(-2, -5, 0.0)
    LIVE(-1, -5, 0.0)
    LIVE(0, -5, 0.0)
    LIVE(1, -5, 0.0)
    LIVE(2, -5, 0.0)
    LIVE(3, -5, 0.0)
    LIVE(4, -5, 0.0)
    LIVE(5, -5, 0.0)
    LIVE(-5, -4, 0.0)
    LIVE(5, -4, 0.0)
    LIVE(-5, -3, 0.0)
    LIVE(5, -3, 0.0)
    LIVE(-5, -2, 0.0)
    LIVE(5, -2, 0.0)
    LIVE(-5, -1, 0.0)
    LIVE(5, -1, 0.0)
    LIVE(-5, 0, 0.0)
    LIVE(5, 0, 0.0)
    LIVE(-5, 1, 0.0)
    LIVE(5, 1, 0.0)
    LIVE(-5, 2, 0.0)
    LIVE(5, 2, 0.0)
    LIVE(-5, 3, 0.0)
    LIVE(5, 3, 0.0)
    LIVE(-5, 4, 0.0)
    LIVE(5, 4, 0.0)
    LIVE(-5, 5, 0.0)
    LIVE(-4, 5, 0.0)
    LIVE(-3, 5, 0.0)
    LIVE(-2, 5, 0.0)
    LIVE(-1, 5, 0.0)
    LIVE(0, 5, 0.0)
    LIVE(1, 5, 0.0)
    LIVE(2, 5, 0.0)
    LIVE(3, 5, 0.0)
    LIVE(4, 5, 0.0)
    LIVE(5, 5, 0.0)
#endif
#endif
    acc.rgb += lit / s;
    f_color = (wsum > 0.0) ? finite4_f32(acc / wsum) : texelFetch(source, src, 0);
}
