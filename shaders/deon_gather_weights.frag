#version 330 core
#pragma vertex_stage "vs/fullscreen.vert"
// The summed step's light-independent half (issue 27; physics/surface_gather.gather_weights, its twin):
// deon_surface_gather.frag's weights, made once per mesh, map size, variance, stretch and reach and kept
// by the graph across light moves; deon_gather_sum.frag sums the light with them. Per texel, in the sum's
// order: the 36 inner texels' w / s (seed 000 eq. 21 with 3D distances: A(y) G(v, |P(x) - P(y)|), < 0
// past a mesh border), then each outer 2 x 2 block's w A_b / s (its moment-matched Gaussian, -1 when not
// summed: another zone, no area, or reached across air), s = |area at x| (1 when 0): the centre is 1.
// Packed 4 to a texel; this draw writes textures GROUP * 8 .. GROUP * 8 + OUTPUTS - 1 (8 targets a draw).
// Computed at the island texel the gutter map names, as the gather is. One line per weight (its index a
// literal), as in deon_gather_sum.frag.
#include "lib/color.glsl"
#ifndef GATHER_BLOCKS
#define GATHER_BLOCKS 3
#endif
#ifndef GROUP
#define GROUP 0
#endif
#ifndef KEPT_RINGS
#define KEPT_RINGS 3  // the rings whose weights are kept (the sum computes the rest itself)
#endif
#ifndef OUTPUTS
#define OUTPUTS 8
#endif
#define LO (32 * GROUP)             // the first weight this draw writes
#define HI (LO + 4 * OUTPUTS)
uniform sampler2D surface;    // deon_gather_surface.frag: xyz mm, w area mm^2 (< 0: no light)
uniform sampler2D gutter;     // RG nearest island texel, B zone
uniform sampler2D blocks_p;   // (BLOCK_SURFACE) xyz mean point (mm), w area
uniform sampler2D blocks_z;   // R zone, G spread (mm^2 per axis)
uniform float u_var;          // variance added, mm^2
uniform sampler2D stretch_map;  // RG UV per mm, B shear cosine
uniform int u_use_stretch;
uniform vec2 u_uniform_stretch;
uniform float u_shortcut;     // SHORTCUT_RATIO (passes/deon.py)
layout(location = 0) out vec4 f_w[OUTPUTS];

// deon_surface_gather.frag's sheet test: 0 when reached across air or a fold
float sheet(vec3 d, vec2 o, float c) {
    return (dot(d, d) < u_shortcut * u_shortcut * (dot(o, o) + 2.0 * c * o.x * o.y)) ? 0.0 : 1.0;
}

// inner texel (I, J) of x's 6 x 6, weight K (when this draw writes it)
#define INNER(I, J, K) if ((K) >= LO && (K) < HI) { ivec2 t = b2 + ivec2(I, J); float inside = (all(greaterThanEqual(t, ivec2(0))) && all(lessThanEqual(t, hi))) ? 1.0 : 0.0; t = clamp(t, ivec2(0), hi); vec4 q = texelFetch(surface, t, 0); float same = (abs(abs(texelFetch(gutter, t, 0).b) - zone) < 0.5) ? 1.0 : 0.0; vec3 d = q.xyz - x; float g = inside * same * sheet(d, vec2(t - src) * mm_per_texel, cs) * abs(q.w) * exp(k * dot(d, d)); w[clamp((K) - LO, 0, 4 * OUTPUTS - 1)] = ((q.w < 0.0) ? -1.0 : 1.0) * min(g / s, 65504.0); }
// block (I, J) from b, weight K: w A_b / s, -1 when not summed
#define BLOCK(I, J, K) if ((K) >= LO && (K) < HI) { ivec2 c = b + ivec2(I, J); float inside = (all(greaterThanEqual(c, ivec2(0))) && all(lessThanEqual(c, bhi))) ? 1.0 : 0.0; c = clamp(c, ivec2(0), bhi); vec4 q = texelFetch(blocks_p, c, 0); vec2 z = texelFetch(blocks_z, c, 0).rg; vec3 d = q.xyz - x; float same = inside * ((abs(z.r - zone) < 0.5 && q.w > 0.0) ? 1.0 : 0.0) * sheet(d, (vec2(2 * c - src) + 0.5) * mm_per_texel, cs); float vb = var + z.g; float g = (var / vb) * exp(-0.5 * dot(d, d) / vb); w[clamp((K) - LO, 0, 4 * OUTPUTS - 1)] = (same > 0.0) ? min(g * q.w / s, 65504.0) : -1.0; }

void main() {
    ivec2 src = ivec2(texelFetch(gutter, ivec2(gl_FragCoord.xy), 0).rg + 0.5);
    float zone = abs(texelFetch(gutter, src, 0).b);
    vec4 xs = texelFetch(surface, src, 0);
    vec3 x = xs.xyz;
    float s = (abs(xs.w) > 0.0) ? abs(xs.w) : 1.0;
    float var = max(u_var, 1e-30);
    float k = -0.5 / var;
    ivec2 hi = textureSize(surface, 0) - 1;
    ivec2 bhi = textureSize(blocks_p, 0) - 1;
    ivec2 b = src >> 1;
    ivec2 b2 = 2 * b;
    vec3 st = (u_use_stretch != 0) ? texelFetch(stretch_map, src, 0).rgb : vec3(u_uniform_stretch, 0.0);
    vec2 mm_per_texel = 1.0 / max(st.rg * vec2(textureSize(surface, 0)), vec2(1e-30));
    float cs = clamp(st.b, -0.95, 0.95);
    float w[4 * OUTPUTS];
    for (int m = 0; m < 4 * OUTPUTS; ++m) w[m] = 0.0;
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
#endif
#endif
#if GATHER_BLOCKS >= 3
#if KEPT_RINGS >= 3
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
#endif
#endif
#if GATHER_BLOCKS >= 4
#if KEPT_RINGS >= 4
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
#endif
#endif
#if GATHER_BLOCKS >= 5
#if KEPT_RINGS >= 5
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
#endif
#endif
#if OUTPUTS > 0
    f_w[0] = vec4(w[0], w[1], w[2], w[3]);
#endif
#if OUTPUTS > 1
    f_w[1] = vec4(w[4], w[5], w[6], w[7]);
#endif
#if OUTPUTS > 2
    f_w[2] = vec4(w[8], w[9], w[10], w[11]);
#endif
#if OUTPUTS > 3
    f_w[3] = vec4(w[12], w[13], w[14], w[15]);
#endif
#if OUTPUTS > 4
    f_w[4] = vec4(w[16], w[17], w[18], w[19]);
#endif
#if OUTPUTS > 5
    f_w[5] = vec4(w[20], w[21], w[22], w[23]);
#endif
#if OUTPUTS > 6
    f_w[6] = vec4(w[24], w[25], w[26], w[27]);
#endif
#if OUTPUTS > 7
    f_w[7] = vec4(w[28], w[29], w[30], w[31]);
#endif
}
