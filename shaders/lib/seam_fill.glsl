// The body of the seam fill (seam_fill.frag, seam_fill_cs.comp): one source for the fragment draw
// and its compute twin.
#ifndef SKINVIEWER_SEAM_FILL_GLSL
#define SKINVIEWER_SEAM_FILL_GLSL
// Seam-aware blur input (issue 10 item 1, issue 14): a copy of `source` whose gutter texels near a
// UV seam hold the value of the surface point they stand for on the adjacent island (the seam map,
// scene/texels.py), so the blur that reads it with plain bilinear taps continues across seams. One
// cheap pass instead of redirecting each tap's four bilinear texels by hand in the blur itself.
uniform sampler2D source;
// Past a mesh border (B = 2) there is no surface: no light (the ground truth integrates over the
// surface only, so skin next to an open border receives less), except the share s.a of the edge's
// value that puts the bilinear ramp's edge where the border is; A (thickness) keeps the edge's value.
uniform sampler2D seam_map;  // RG: texel coordinate across the UV seam, B: 1 there, 2 past a border
uniform int u_past_border_dark;  // 1 for light; 0 for a metric (the stretch chain): the edge's value
// DOWN (deon.half_res_above_texels): this fill is half the source's size, the input of a half-size blur:
// each texel reads the source filtered at its centre (the 2 x 2 full-size texels around it); the seam
// map and the gutter map are this fill's size. It always reads at the island texel the gutter map names
// (as DILATE), so the half-size gutters hold the half-size islands' values with and without skip_gutters.
#ifdef DOWN
#define AT_TEXEL(t) texture(source, (vec2(t) + 0.5) / vec2(textureSize(seam_map, 0)))
#else
#define AT_TEXEL(t) texelFetch(source, t, 0)
#endif
#if defined(DILATE) || defined(DOWN)
// the source was drawn on the island tiles only (deon.skip_gutters, issue 27): every texel reads its
// value at the island texel the gutter map names, as the blur computed it there; the fill also dilates
uniform sampler2D gutter;  // RG: the nearest island texel
#endif
#ifdef OPEN_BORDER
// a blur of E (not E itself): past the border the odd reflection of the light (lib/open_border.glsl)
#include "lib/open_border.glsl"
uniform int u_reflect;
// the direct gather's input (deon_surface_gather.frag, a point per texel with its whole area): an island
// texel the border line crosses carries its share on the surface, c = 1/2 + s / (2 h) for its centre s
// texels in and h its half extent along the normal (numpy twin: physics/open_border.rim_share), as the separable
// blur's whole-texel taps count it; the rest of its area lies past the border and holds no light. Its
// own variant (RIM_SHARE), not a uniform: the separable blurs use the OPEN_BORDER program too
#endif
// the filled value of output texel p (seam_fill.frag draws it, seam_fill_cs.comp stores it)
vec4 seam_fill_at(ivec2 p) {
#if defined(DILATE) || defined(DOWN)
    vec4 here = AT_TEXEL(ivec2(texelFetch(gutter, p, 0).rg + 0.5));
#else
    vec4 here = AT_TEXEL(p);
#endif
#if defined(NO_SEAM) && !defined(OPEN_BORDER)
    // drawn on the tiles with no texel across a seam or past a border (passes/deon.seam_split, issue 27):
    // the copy at the island texel that the lines below give there, without their seam lookup, which a
    // SIMD rasteriser would run masked on every texel
    return here;
#endif
    vec4 s = texelFetch(seam_map, p, 0);
#ifdef OPEN_BORDER
    vec4 bf = texelFetch(border_map, p, 0);
    if (u_reflect != 0 && u_past_border_dark != 0 && s.b > 1.5 && bf.a > 0.5 && bf.r < 0.0) {
        vec2 uv = (vec2(p) + 0.5) / vec2(textureSize(source, 0));
        return past_border_light(source, uv, bf.r, bf.gb, border_half_e(uv, bf.r, bf.gb));
    }
#ifdef RIM_SHARE
    float h = 0.5 * (abs(bf.g) + abs(bf.b));
    if (s.b < 0.5 && bf.a > 0.5 && bf.r >= 0.0 && bf.r < h) {
        return vec4((0.5 + 0.5 * bf.r / h) * here.rgb, here.a);
    }
#endif
#endif
    return (s.b > 1.5 && u_past_border_dark != 0) ? vec4(here.rgb * s.a, here.a)
            : (s.b > 0.5 && s.b < 1.5) ? texture(source, (s.rg + 0.5) / vec2(textureSize(seam_map, 0))) : here;
}
#endif
