#version 330 core
#pragma vertex_stage "vs/fullscreen.vert"
// One Gosselin Poisson blur iteration (seed 000 eq. 11-13):
//   size = 1 / (width, height)                                   (11)
//   radius = size * R, R from the radius map (texels, eq. 12)    (12)
//   pixel = (centre + sum_i source(coord + poisson(i) * radius)) / 13   (13)
// Taps are bilinear on a gutter-dilated source, CLAMP_TO_EDGE; with scene.seam_aware the source is
// the seam-filled copy (seam_fill.frag), so taps that leave their island continue across UV seams.
#include "lib/island_zones.glsl"
in vec2 v_uv;
uniform sampler2D source;
uniform sampler2D radius_map;  // R32F, per texel radius in texels (eq. 12 without size)
uniform vec2 u_poisson[12];    // skinviewer.poisson.POISSON_12
#ifdef RADIUS_MM
// gosselin.radius_mode "mm" (issue 10 item 6): radius per channel in mm (physics/poisson.radii_mm),
// UV per mm from the stretch map (seed 000 eq. 27): each channel taps at its own radius
uniform vec3 u_radius_mm;
uniform sampler2D stretch_map;
#endif
uniform sampler2D gutter;      // gutter map: B island zone (negative on its border), A texels to another
#ifdef ISLAND_ZONES
uniform sampler2D seam_map;    // A: 1 where the nearest island edge is a mesh border
#endif
out vec4 f_color;

vec4 finite4(vec4 c) {
    bvec4 bad = bvec4(isnan(c.x) || isinf(c.x), isnan(c.y) || isinf(c.y),
                      isnan(c.z) || isinf(c.z), isnan(c.w) || isinf(c.w));
    return clamp(mix(c, vec4(0.0), bad), vec4(0.0), vec4(FLOAT_MAX));
}

// 1 when a tap at t (UV) reads island zone `zone` only (lib/island_zones.glsl): with scene.seam_aware
// (ISLAND_ZONES) a tap that would land on another UV island is dropped and (13) divides by the taps
// kept, so no light crosses a UV gutter; 1 for every tap otherwise.
float kept(vec2 t, float zone, bool check) {
#ifdef ISLAND_ZONES
    if (check) return in_zone(gutter, ivec2(floor(t * vec2(textureSize(gutter, 0)))), zone, true);
#endif
    return 1.0;
}

void main() {
    ivec2 p = ivec2(gl_FragCoord.xy);
    vec2 size = 1.0 / vec2(textureSize(source, 0));          // (11)
    vec2 uv = (vec2(p) + 0.5) * size;
    vec4 sum = finite4(texelFetch(source, p, 0));
    vec4 own = texelFetch(gutter, p, 0);
    float zone = abs(own.b);
#ifdef ISLAND_ZONES
    float absorb = texelFetch(seam_map, ivec2(own.rg + 0.5), 0).a;  // a dropped tap is past the surface's end
#else
    float absorb = 0.0;
#endif
#ifdef RADIUS_MM
    vec2 s = clamp(texelFetch(stretch_map, p, 0).rg, vec2(0.0), vec2(10.0));  // UV per mm
    vec3 R = clamp(u_radius_mm, vec3(0.0), vec3(1e3));
    bool check = max(R.r, max(R.g, R.b)) * max(s.x, s.y) / size.x + 1.5 > own.a;
    vec4 cnt = vec4(1.0);
    for (int i = 0; i < 12; ++i) {
        vec2 o = u_poisson[i] * s;
        vec3 k = vec3(kept(uv + o * R.r, zone, check), kept(uv + o * R.g, zone, check), kept(uv + o * R.b, zone, check));
        vec4 r = finite4(texture(source, uv + o * R.r));
        sum += vec4(k.r * r.r, k.g * finite4(texture(source, uv + o * R.g)).g,
                    k.b * finite4(texture(source, uv + o * R.b)).b, k.r * r.a);
        cnt += max(k.rgbr, vec4(absorb));
    }
#else
    float R = texelFetch(radius_map, p, 0).r;
    R = (R >= 0.0 && R <= 1e6) ? R : 0.0;                       // also rejects NaN
    vec2 radius = size * R;                                     // (12)
    bool check = R + 1.5 > own.a;
    float cnt = 1.0;
    for (int i = 0; i < 12; ++i) {
        float k = kept(uv + u_poisson[i] * radius, zone, check);
        sum += k * finite4(texture(source, uv + u_poisson[i] * radius));
        cnt += max(k, absorb);
    }
#endif
    f_color = finite4(sum / cnt);                               // (13): 13 taps when none is dropped
}
