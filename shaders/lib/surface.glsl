// Surface inputs from the mesh's maps (albedo linear, tangent-space normal map).
#ifndef SKINVIEWER_SURFACE_GLSL
#define SKINVIEWER_SURFACE_GLSL
uniform sampler2D albedo_map;   // linear RGB
uniform sampler2D normal_map;   // tangent space, n * 0.5 + 0.5
uniform int u_has_normal_map;
// The footprint the surface maps are read with, in uv: (0, 0) lets the rasteriser's derivatives pick
// the mip level (screen space); a texture-space pass sets one texel of its target, so the level is the
// same on every GL whichever path shades the texel (rasterised triangles or a full-screen draw over the
// texel surface map, whose 2 x 2 quads straddle triangles: the derivatives round differently there).
vec2 g_surface_footprint = vec2(0.0);

vec4 surface_map(sampler2D map, vec2 uv) {
    if (g_surface_footprint.x > 0.0)
        return textureGrad(map, uv, vec2(g_surface_footprint.x, 0.0), vec2(0.0, g_surface_footprint.y));
    return texture(map, uv);
}

vec3 surface_normal(vec3 n, vec4 t, vec2 uv) {
    vec3 N = normalize(n);
    if (u_has_normal_map == 0) return N;
    vec3 T = t.xyz - N * dot(N, t.xyz);
    float tl = length(T);
    if (tl < 1e-6) return N;
    T /= tl;
    vec3 B = cross(N, T) * (t.w < 0.0 ? -1.0 : 1.0);
    vec3 m = surface_map(normal_map, uv).xyz * 2.0 - 1.0;
    vec3 P = T * m.x + B * m.y + N * m.z;
    float pl = length(P);
    return pl > 1e-6 ? P / pl : N;
}
#endif
