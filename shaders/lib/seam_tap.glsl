// Seam-aware texture taps for the texture-space blurs (issue 10 item 1).
#ifndef SKINVIEWER_SEAM_TAP_GLSL
#define SKINVIEWER_SEAM_TAP_GLSL
uniform sampler2D seam_map;  // RG: texel coordinate across the UV seam, B: 1 where there is one (seam_N)
uniform int u_seam;          // scene.seam_aware
// A tap that leaves its island continues on the island adjacent across the UV seam (issue 10
// item 1): the seam map names, for gutter texels near a seam, the surface point they stand for.
vec4 seam_tap(sampler2D source, vec2 uv) {
    if (u_seam == 0) return texture(source, uv);
    ivec2 size = textureSize(source, 0);
    vec2 t = uv * vec2(size) - 0.5;
    ivec2 i0 = ivec2(floor(t));
    vec2 f = t - vec2(i0);
    vec4 s00 = texelFetch(seam_map, clamp(i0, ivec2(0), size - 1), 0);
    vec4 s10 = texelFetch(seam_map, clamp(i0 + ivec2(1, 0), ivec2(0), size - 1), 0);
    vec4 s01 = texelFetch(seam_map, clamp(i0 + ivec2(0, 1), ivec2(0), size - 1), 0);
    vec4 s11 = texelFetch(seam_map, clamp(i0 + ivec2(1, 1), ivec2(0), size - 1), 0);
    if (s00.b + s10.b + s01.b + s11.b < 0.5) return texture(source, uv);
    // bilinear by hand, each of the four texels read where the surface continues
    vec2 inv = 1.0 / vec2(size);
    vec4 c00 = s00.b > 0.5 ? texture(source, (s00.rg + 0.5) * inv) : texelFetch(source, clamp(i0, ivec2(0), size - 1), 0);
    vec4 c10 = s10.b > 0.5 ? texture(source, (s10.rg + 0.5) * inv) : texelFetch(source, clamp(i0 + ivec2(1, 0), ivec2(0), size - 1), 0);
    vec4 c01 = s01.b > 0.5 ? texture(source, (s01.rg + 0.5) * inv) : texelFetch(source, clamp(i0 + ivec2(0, 1), ivec2(0), size - 1), 0);
    vec4 c11 = s11.b > 0.5 ? texture(source, (s11.rg + 0.5) * inv) : texelFetch(source, clamp(i0 + ivec2(1, 1), ivec2(0), size - 1), 0);
    return mix(mix(c00, c10, f.x), mix(c01, c11, f.x), f.y);
}
#endif
