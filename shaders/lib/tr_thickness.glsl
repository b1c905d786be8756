// Jimenez 2010 transmittance (seed 001 §3.5, eq. 3.18; spec §6.2), its first half: the thickness a
// shadow-casting light's ray crossed to reach a point, from that light's shadow map. Used by the
// screen-space lighting (ss_lighting.frag) and pre-integrated skin (penner.frag); the profile T(d) is
// lib/tr_profile.glsl. Needs lib/lights.glsl first.
#ifndef LIB_TR_THICKNESS_GLSL
#define LIB_TR_THICKNESS_GLSL
uniform float u_mm_per_unit;
uniform mat4 u_light_matrix_inv[MAX_LIGHTS];
uniform int u_shadow_map_size;

float shadow_sample(int i, vec2 c) {
    if (i == 0) return texture(shadow_map0, c).r;
    if (i == 1) return texture(shadow_map1, c).r;
    if (i == 2) return texture(shadow_map2, c).r;
    return texture(shadow_map3, c).r;
}

// The thickness from light i's shadow map (seed 001 §3.5, Green's s = z_out - z_in): the shadow
// map's nearest surface A unprojected, its distance (mm) to the point shrunk by a shadow texel along
// the normal (spec §6.2 steps 2-4). The thickness is averaged over 3x3 shadow texels: the thickness of nearly lit
// points is a texel-quantised few tenths of a mm, which would print the shadow map's grid as moire.
// Returns (n / 9, thickness mm): T = (n / 9) T(thickness x scale) (ss_transmittance.frag).
vec2 transmitted(int i, vec3 P, vec3 Ng) {
    vec3 Ps = P - Ng * u_shadow_texel[i];
    vec4 p = u_light_matrix[i] * vec4(Ps, 1.0);
    if ((isnan(p.w) || p.w <= 0.0)) return vec2(0.0);
    vec3 c = p.xyz / p.w * 0.5 + 0.5;
    if (any(lessThan(c.xy, vec2(0.0))) || any(greaterThan(c.xy, vec2(1.0)))) return vec2(0.0);
    vec2 texel = 1.0 / vec2(u_shadow_map_size);
    vec3 Lv = LIGHT_IS_POINT(i) ? normalize(u_light_pos[i] - Ps) : u_light_dir[i];
    // a lit point's own depth differs from the texel-centre depth by up to tan(N, L) / 2 texels:
    // that much thickness is quantisation, not tissue (the slope-scaled tolerance of the shadow test)
    float nl = abs(dot(Ng, Lv));
    float tan_nl = sqrt(max(1.0 - nl * nl, 0.0)) / max(nl, 0.25);
    float tol_mm = u_shadow_texel[i] * (0.5 + 0.5 * tan_nl) * u_mm_per_unit;
    // the thickness (not T) is averaged: one profile evaluation per light
    float d_sum = 0.0, n = 0.0;
    for (int y = -1; y <= 1; ++y) for (int x = -1; x <= 1; ++x) {
        vec2 cc = c.xy + vec2(x, y) * texel;
        float ds = shadow_sample(i, cc);
        if (ds >= 1.0) continue;  // no surface in front: nothing crossed
        vec4 a = u_light_matrix_inv[i] * vec4(cc * 2.0 - 1.0, ds * 2.0 - 1.0, 1.0);
        if ((isnan(abs(a.w)) || abs(a.w) <= 1e-30)) continue;
        // the distance along the light (not the lateral texel offset), less the quantisation
        d_sum += max(abs(dot(a.xyz / a.w - Ps, Lv)) * u_mm_per_unit - tol_mm, 0.0);
        n += 1.0;
    }
    if (n < 0.5) return vec2(0.0);
    return vec2(n / 9.0, d_sum / n);
}
#endif
