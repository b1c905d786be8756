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
// One line per tap (lib/gather_sum_taps.glsl), its weight's index a literal (a loop left rolled by the
// compiler would index the weights dynamically). deon_gather_quad.frag computes the same sums four texels
// at a time (a software rasterizer: the taps they share fetched once).
#include "lib/color.glsl"
#include "lib/gather_surface.glsl"
#ifndef GATHER_BLOCKS
#define GATHER_BLOCKS 3
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
#include "lib/gather_weight_maps.glsl"
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
    WEIGHTS_AT(W, 0, p)
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
#include "lib/gather_sum_taps.glsl"
    acc.rgb += lit / s;
    f_color = (wsum > 0.0) ? finite4_f32(acc / wsum) : texelFetch(source, src, 0);
}
