#version 330 core
#pragma vertex_stage "vs/fullscreen.vert"
// A narrow blur step as a direct sum over the surface (issue 10 item 1; seed 000 eq. 21 with 3D
// distances, the ground truth's sum at texel resolution), instead of the separable taps of eq. 25-26
// that assume the surface flat and the stretch constant over the kernel:
//   out(x) = sum_y G(v, |P(x) - P(y)|) E(y) A(y) / sum_y G(v, |P(x) - P(y)|) A(y)
// y: the 36 texels of the 3 x 3 blocks of 2 x 2 around x's block, then 2 x 2 blocks, each a Gaussian
// widened by its own spread (its area at its mean point, its light at the light's), out to GATHER_BLOCKS
// blocks (2 GATHER_BLOCKS + 2 texels: 3.5 sigma at 1.6 x the step's sigma in mean texels,
// physics/surface_gather.gather_blocks_for, 5 at most). Only x's island zone counts: its seam-filled gutter continues across seams; area past a
// mesh border counts, but only the light of the part still on the surface (lib/gather_surface.glsl).
// A texel much nearer in 3D than its offset along the surface (from the stretch at x, eq. 27 with
// shear) is reached across air or a fold (lips, lids, ear folds touching), not along x's sheet: left
// out, as a texture-space blur leaves it (physics/surface_gather.py says why).
// Computed at the island texel the gutter map names, so gutters come out dilated.
#include "lib/color.glsl"
#include "lib/gather_surface.glsl"
#ifndef GATHER_BLOCKS
#define GATHER_BLOCKS 5  // physics/surface_gather.GATHER_BLOCKS, which the pass defines
#endif
uniform sampler2D source;     // the blur's input, seam-filled
uniform sampler2D surface;    // deon_gather_surface.frag: xyz mm, w area mm^2 (< 0: no light)
uniform sampler2D gutter;     // RG nearest island texel, B zone
uniform sampler2D blocks_e;   // deon_gather_blocks.frag: sum E A
uniform sampler2D blocks_p;   // (BLOCK_SURFACE, once per mesh) xyz mean point (mm), w area
uniform sampler2D blocks_z;   // R zone, G spread (mm^2 per axis)
uniform sampler2D blocks_l;   // xyz the light's mean point, w its spread
uniform float u_var;          // variance added, mm^2
uniform sampler2D stretch_map;  // RG UV per mm, B shear cosine
uniform int u_use_stretch;
uniform vec2 u_uniform_stretch;
uniform float u_shortcut;     // SHORTCUT_RATIO (passes/deon.py)
out vec4 f_color;

// 0 for a texel at offset d (3D) that is nearer than u_shortcut x its offset o along the surface (mm
// in the tangent plane at x, eq. 27 with shear c): reached across air or a fold, not along x's sheet
float sheet(vec3 d, vec2 o, float c) {
    return (dot(d, d) < u_shortcut * u_shortcut * (dot(o, o) + 2.0 * c * o.x * o.y)) ? 0.0 : 1.0;
}

void main() {
    ivec2 src = ivec2(texelFetch(gutter, ivec2(gl_FragCoord.xy), 0).rg + 0.5);
    float zone = abs(texelFetch(gutter, src, 0).b);
    vec3 x = texelFetch(surface, src, 0).xyz;
    float var = max(u_var, 1e-30);
    float k = -0.5 / var;
    ivec2 hi = textureSize(source, 0) - 1;
    ivec2 bhi = textureSize(blocks_p, 0) - 1;
    ivec2 b = src >> 1;
    vec4 acc = vec4(0.0);
    float wsum = 0.0;
    vec3 st = (u_use_stretch != 0) ? texelFetch(stretch_map, src, 0).rgb : vec3(u_uniform_stretch, 0.0);
    vec2 mm_per_texel = 1.0 / max(st.rg * vec2(textureSize(source, 0)), vec2(1e-30));
    float cs = clamp(st.b, -0.95, 0.95);
    for (int j = -2; j < 4; ++j) {
        for (int i = -2; i < 4; ++i) {
            ivec2 t = 2 * b + ivec2(i, j);
            float inside = (all(greaterThanEqual(t, ivec2(0))) && all(lessThanEqual(t, hi))) ? 1.0 : 0.0;
            t = clamp(t, ivec2(0), hi);
            vec4 s = texelFetch(surface, t, 0);
            float same = (abs(abs(texelFetch(gutter, t, 0).b) - zone) < 0.5) ? 1.0 : 0.0;
            vec3 d = s.xyz - x;
            float w = inside * same * sheet(d, vec2(t - src) * mm_per_texel, cs) * abs(s.w) * exp(k * dot(d, d));
            vec4 e = texelFetch(source, t, 0);
            acc += w * vec4((s.w > 0.0) ? e.rgb : PAST_BORDER_SHARE * e.rgb, e.a);
            wsum += w;
        }
    }
    for (int j = -GATHER_BLOCKS; j <= GATHER_BLOCKS; ++j) {
        for (int i = -GATHER_BLOCKS; i <= GATHER_BLOCKS; ++i) {
            if (max(abs(i), abs(j)) <= 1) continue;  // the inner 3 x 3 blocks: texel by texel above (uniform branch)
            ivec2 c = b + ivec2(i, j);
            float inside = (all(greaterThanEqual(c, ivec2(0))) && all(lessThanEqual(c, bhi))) ? 1.0 : 0.0;
            c = clamp(c, ivec2(0), bhi);
            vec4 p = texelFetch(blocks_p, c, 0);
            vec2 z = texelFetch(blocks_z, c, 0).rg;
            float same = (abs(z.r - zone) < 0.5 && p.w > 0.0) ? 1.0 : 0.0;
            vec3 d = p.xyz - x;
            same *= inside * sheet(d, (vec2(2 * c - src) + 0.5) * mm_per_texel, cs);
            // G(v + s^2, r) of the block's own spread s^2, relative to G(v, .) of single texels: for
            // its area (the normalisation, thickness) and, at the light's own mean point, its light
            float vb = var + z.g;
            float w = same * (var / vb) * exp(-0.5 * dot(d, d) / vb);
            vec4 l = texelFetch(blocks_l, c, 0);
            vec3 dl = l.xyz - x;
            float vl = var + l.w;
            float wl = same * (var / vl) * exp(-0.5 * dot(dl, dl) / vl);
            vec4 e = texelFetch(blocks_e, c, 0);
            acc += vec4(wl * e.rgb, w * e.a);
            wsum += w * p.w;
        }
    }
    f_color = (wsum > 0.0) ? finite4_f32(acc / wsum) : texelFetch(source, src, 0);
}
