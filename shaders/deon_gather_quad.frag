#version 330 core
#pragma vertex_stage "vs/fullscreen.vert"
// deon_gather_sum.frag four texels at a time (issue 27, a software rasterizer: passes/deon.quad_sum): one
// fragment per 2 x 2 block B of the map, drawn at half size, sums the four island texels 2 B + (i, j).
// They share their inner 6 x 6 texels and their blocks (b = B), so each tap's E, block light and mean
// point are fetched once for the four, where the one-texel sum fetches them four times (llvmpipe pays per
// fetch and lane: 135 fetches a texel -> 49). Each texel's sum is deon_gather_sum.frag's, term by term
// in the same order (bit-identical; tests/test_gather_quad.py). Out: texel 2 B + (i, j) in f_q[i + 2 j].
// Only island texels are meant: a gutter texel's sum is its island texel's (the weights at it are the
// ones made for that texel), which deon_gather_pick.frag fetches. Rings past KEPT_RINGS: their weights
// computed per texel here (LIVE), as deon_gather_sum.frag computes them.
#include "lib/color.glsl"
#include "lib/gather_surface.glsl"
#ifndef GATHER_BLOCKS
#define GATHER_BLOCKS 3
#endif
#ifndef LIT_RING
#define LIT_RING GATHER_BLOCKS
#endif
#ifndef KEPT_RINGS
#define KEPT_RINGS 3
#endif
uniform sampler2D source;     // the blur's input, seam-filled
uniform sampler2D surface;    // deon_gather_surface.frag: xyz mm, w area mm^2
uniform sampler2D blocks_e;   // deon_gather_blocks.frag MEAN_THICKNESS: RGB sum E A, A the mean thickness
uniform sampler2D blocks_l;   // xyz the light's mean point, w its spread
uniform sampler2D blocks_m;   // (LIT_RING < GATHER_BLOCKS) RGB the mean light sum E A / sum A
uniform float u_var;          // variance added, mm^2
#if GATHER_BLOCKS > KEPT_RINGS  // the rings past KEPT_RINGS: their weights computed here (deon_gather_sum.frag)
uniform sampler2D gutter;     // B zone
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
layout(location = 0) out vec4 f_q[4];
#define WT WEIGHT_TEXTURES

// deon_gather_sum.frag's INNER, BLOCK and FLAT, the tap's fetch shared by texels 0..3
#define INNER_T(T, K, e) { float w = W[(T) * WT + ((K) >> 2)][(K) & 3]; float a = abs(w); acc[T] += a * vec4((w > 0.0) ? e.rgb : PAST_BORDER_SHARE * e.rgb, e.a); wsum[T] += a; }
#define INNER(I, J, K) { vec4 e = texelFetch(source, clamp(b2 + ivec2(I, J), ivec2(0), hi), 0); INNER_T(0, K, e) INNER_T(1, K, e) INNER_T(2, K, e) INNER_T(3, K, e) }
#define BLOCK_T(T, K) { float w = W[(T) * WT + ((K) >> 2)][(K) & 3]; float a = max(w, 0.0); acc[T].a += a * e.a; wsum[T] += a; vec3 dl = l.xyz - x[T]; lit[T] += ((w >= 0.0) ? (var / vl) * exp(-0.5 * dot(dl, dl) / vl) : 0.0) * e.rgb; }
#define BLOCK(I, J, K) { ivec2 c = clamp(b + ivec2(I, J), ivec2(0), bhi); vec4 e = texelFetch(blocks_e, c, 0); vec4 l = texelFetch(blocks_l, c, 0); float vl = var + l.w; BLOCK_T(0, K) BLOCK_T(1, K) BLOCK_T(2, K) BLOCK_T(3, K) }
#define FLAT_T(T, K) { float a = max(W[(T) * WT + ((K) >> 2)][(K) & 3], 0.0); acc[T] += a * m; wsum[T] += a; }
#define FLAT(I, J, K) { vec4 m = texelFetch(blocks_m, clamp(b + ivec2(I, J), ivec2(0), bhi), 0); FLAT_T(0, K) FLAT_T(1, K) FLAT_T(2, K) FLAT_T(3, K) }
// deon_gather_sum.frag's LIVE: the block's point, zone and light fetched once, its weight per texel
#define LIVE_T(T, LITP) { vec3 d = q.xyz - x[T]; float same = inside * ((abs(z.r - zone[T]) < 0.5 && q.w > 0.0) ? 1.0 : 0.0) * sheet(d, (vec2(2 * c - (b2 + ivec2((T) & 1, (T) >> 1))) + 0.5) * mm_per_texel[T], cs[T]); float vb = var + z.g; float a = same * min((var / vb) * exp(-0.5 * dot(d, d) / vb) * q.w / s[T], 65504.0); if (LITP > 0.5) { acc[T].a += a * e.a; vec3 dl = l.xyz - x[T]; float vl = var + l.w; lit[T] += same * (var / vl) * exp(-0.5 * dot(dl, dl) / vl) * e.rgb; } else { acc[T] += a * m; } wsum[T] += a; }
#define LIVE(I, J, LITP) { ivec2 c = b + ivec2(I, J); float inside = (all(greaterThanEqual(c, ivec2(0))) && all(lessThanEqual(c, bhi))) ? 1.0 : 0.0; c = clamp(c, ivec2(0), bhi); vec4 q = texelFetch(blocks_p, c, 0); vec2 z = texelFetch(blocks_z, c, 0).rg; vec4 e = vec4(0.0), l = vec4(0.0), m = vec4(0.0); if (LITP > 0.5) { e = texelFetch(blocks_e, c, 0); l = texelFetch(blocks_l, c, 0); } else { m = texelFetch(blocks_m, c, 0); } LIVE_T(0, LITP) LIVE_T(1, LITP) LIVE_T(2, LITP) LIVE_T(3, LITP) }

void main() {
    ivec2 b = ivec2(gl_FragCoord.xy);
    ivec2 b2 = 2 * b;
    ivec2 hi = textureSize(source, 0) - 1;
    ivec2 bhi = textureSize(blocks_e, 0) - 1;
    float var = max(u_var, 1e-30);
    vec3 x[4];
    float s[4];
    vec4 W[4 * WT];
    vec4 acc[4];
    float wsum[4];
    vec3 lit[4];
#if GATHER_BLOCKS > KEPT_RINGS
    float zone[4], cs[4];
    vec2 mm_per_texel[4];
#endif
    for (int t = 0; t < 4; ++t) {  // texel t = 2 b + (t & 1, t >> 1), as deon_gather_sum.frag's x and s
        ivec2 q = min(b2 + ivec2(t & 1, t >> 1), hi);
        vec4 xs = texelFetch(surface, q, 0);
        x[t] = xs.xyz;
        s[t] = (abs(xs.w) > 0.0) ? abs(xs.w) : 1.0;
        acc[t] = vec4(0.0);
        wsum[t] = 0.0;
        lit[t] = vec3(0.0);
#if GATHER_BLOCKS > KEPT_RINGS
        zone[t] = abs(texelFetch(gutter, q, 0).b);
        vec3 st = (u_use_stretch != 0) ? texelFetch(stretch_map, q, 0).rgb : vec3(u_uniform_stretch, 0.0);
        mm_per_texel[t] = 1.0 / max(st.rg * vec2(textureSize(source, 0)), vec2(1e-30));
        cs[t] = clamp(st.b, -0.95, 0.95);
#endif
    }
    WEIGHTS_AT(W, 0, b2)
    WEIGHTS_AT(W, WT, min(b2 + ivec2(1, 0), hi))
    WEIGHTS_AT(W, 2 * WT, min(b2 + ivec2(0, 1), hi))
    WEIGHTS_AT(W, 3 * WT, min(b2 + ivec2(1, 1), hi))
#include "lib/gather_sum_taps.glsl"
    for (int t = 0; t < 4; ++t) {
        acc[t].rgb += lit[t] / s[t];
        f_q[t] = (wsum[t] > 0.0) ? finite4_f32(acc[t] / wsum[t]) : texelFetch(source, min(b2 + ivec2(t & 1, t >> 1), hi), 0);
    }
}
