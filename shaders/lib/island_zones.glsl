// UV island zones of the gutter map (passes/texture_space.gutter_table): B = the zone of the island
// nearest to a texel, negative on the zone's border (an 8-neighbour in another zone); A = the distance
// (texels) to that border. A blur tap in another island's zone would read an unrelated part of the
// surface across a UV gutter (issue 10), so the texture-space blurs drop it.
#ifndef SKINVIEWER_ISLAND_ZONES_GLSL
#define SKINVIEWER_ISLAND_ZONES_GLSL
// 1 when texel t reads zone `zone` only. A bilinear tap (`blend`) is judged by its nearest texel: if
// that is inside the zone and off its border, so are all four texels the tap blends; a whole-texel
// tap reads t alone, border or not.
float in_zone(sampler2D gutter, ivec2 t, float zone, bool blend) {
    float b = texelFetch(gutter, clamp(t, ivec2(0), textureSize(gutter, 0) - 1), 0).b;
    return (abs((blend ? b : abs(b)) - zone) < 0.5) ? 1.0 : 0.0;
}
// the zone of the texel under uv
float uv_zone(sampler2D gutter, vec2 uv) {
    ivec2 n = textureSize(gutter, 0);
    return abs(texelFetch(gutter, clamp(ivec2(floor(uv * vec2(n))), ivec2(0), n - 1), 0).b);
}
#endif
