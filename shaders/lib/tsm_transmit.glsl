// Transmission through the body from the TSM light (seed 000 eq. 33 / §4.2.7, seed 002 §14.5),
// issue 10 items 3-4. Included by deon_final.frag after FETCH_BLURS, uv_per_mm and its uniforms.
// C = the shaded point; A_k = the lit point stored in TSM texel k of the 3x3 texels around C's
// (filtered like PCF, so the transmission neither steps nor hatches with TSM texels);
// m_k = d(C) - d(A_k), the path length C..A_k along the light ray = their 3D distance;
// r_k = the surface distance C..A_k measured in texture space (stretch of C and A).
//  * Eq. 33 replaces C by B, the point at depth d = m cos(theta) below A (seed 000 §4.2.7 accepts
//    the error "for large theta"). Near every light terminator theta -> 90 deg, d -> 0 while C is
//    m away: full transmission on the dark side, a red line. Here the profile is evaluated at
//    the true distance m: G(v, sqrt(r^2 + m^2)) = G(v, r) exp(-m^2 / 2v).
//  * The texture-space blur at C already carries A's light over the surface distance r (weight
//    exp(-r^2 / 2v) relative to r = 0); the path through the body adds only the difference,
//    exp(-m^2 / 2v) - exp(-r^2 / 2v) >= 0 (m <= r up to sampling). Near a terminator of a convex
//    surface m ~ r: nothing is counted twice; through an ear r >> m: the full eq. 33 term.
//    Only when A lies in C's UV island zone (the gutter map's B): a blur never crosses into another
//    island, so for A on another island (the far side of an ear or a flap cut into two islands)
//    nothing is carried and the full term counts.
//  * A_k is C itself (lit) when m_k is within the TSM's depth uncertainty: a constant tolerance
//    (u_tsm_gate_mm, two TSM texels) plus the depth slope across a texel at A, texel * tan(theta)
//    (slope-scaled bias), faded in smoothly from tol to 2 tol (thickness fade).
#ifndef SKINVIEWER_TSM_TRANSMIT_GLSL
#define SKINVIEWER_TSM_TRANSMIT_GLSL
#include "lib/island_zones.glsl"
vec3 tsm_transmitted(vec3 P, vec2 uvC) {
    vec4 p = u_tsm_matrix * vec4(P, 1.0);
    if (!(p.w > 0.0)) return vec3(0.0);
    vec2 c = p.xy / p.w * 0.5 + 0.5;
    if (any(lessThan(c, vec2(0.0))) || any(greaterThan(c, vec2(1.0)))) return vec3(0.0);
    vec4 t0 = texture(tsm_map, c);
    if (t0.a < 0.0) return vec3(0.0);  // no surface towards the light
    vec2 texel = 1.0 / vec2(textureSize(tsm_map, 0));
    float dC = tsm_distance_mm(P);
    vec2 s = 0.5 * (uv_per_mm(uvC) + uv_per_mm(t0.gb));
    float k2 = (u_tsm_printed != 0) ? 1.0 : 2.0;  // eq. 33 as printed: exp(-x^2 / v)
    float zoneC = uv_zone(zone_map, uvC);
    float f[MAX_GAUSSIANS];
    for (int i = 0; i < MAX_GAUSSIANS; ++i) f[i] = 0.0;
    bool any_k = false;
    for (int y = -1; y <= 1; ++y) for (int x = -1; x <= 1; ++x) {
        vec4 t = texture(tsm_map, c + vec2(x, y) * texel);
        if (t.a < 0.0) continue;
        float m = finite_f32(dC - t.r);
        float cosA = clamp(t.a, 0.05, 1.0);
        float tol = u_tsm_gate_mm * (1.0 + 0.5 * sqrt(1.0 - cosA * cosA) / cosA);
        float g = smoothstep(tol, 2.0 * tol, m);
        if (!(g > 0.0)) continue;
        any_k = true;
        float r = (abs(uv_zone(zone_map, t.gb) - zoneC) < 0.5) ? length((uvC - t.gb) / s) : 1e18;
        for (int i = 0; i < MAX_GAUSSIANS; ++i) {
            if (i >= u_count) break;
            float v = u_var[i];
            if (((G_MASK >> i) & 1) == 0 || u_used[i] == 0 || !(v > 0.0)) continue;
            f[i] += g * max(exp(-m * m / (k2 * v)) - exp(-r * r / (k2 * v)), 0.0);
        }
    }
    if (!any_k) return vec3(0.0);
    vec4 there[MAX_GAUSSIANS];
    FETCH_BLURS(there, t0.gb, THERE_MASK)
    vec3 acc = vec3(0.0);
    for (int i = 0; i < MAX_GAUSSIANS; ++i) {
        if (i >= u_count) break;
        if (((G_MASK >> i) & 1) != 0 && u_used[i] != 0) acc += u_w[i] * (f[i] / 9.0) * there[i].rgb;
    }
    return acc;
}
#endif
