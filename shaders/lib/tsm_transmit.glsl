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
//  * Gathered (deon.tsm_gather): a Gaussian wider than two TSM texels does not take A's blur on the
//    ray but integrates the first surfaces around it in light space, G(v, |C - A(p)|) E(A(p)) dA =
//    G2(v, |p|) exp(-m(p)^2 / 2v) E/cos(theta) dp: TSM_GATHER_N samples of the lateral Gaussian
//    (importance sampled, a fixed spiral), each with its own distance m(p) and E(A(p)) / cos, less the same
//    surface-blur share. Every directly lit point is some TSM texel's A, so this is the ground
//    truth's sum over lit points for this light; on the ray alone, a fold whose near sheet is lit
//    just beside the ray (an ear lit from behind) stays dark (issue 10 item 4).
#ifndef SKINVIEWER_TSM_TRANSMIT_GLSL
#define SKINVIEWER_TSM_TRANSMIT_GLSL
#include "lib/island_zones.glsl"
#ifndef TSM_GATHER_N
#define TSM_GATHER_N 0
#endif
// TSM_SKIP (deon_transmitted, issue 27): a texel C that no TSM read within reach can bring near
// enough returns 0 before its loops. Every term is exp(-m^2 / (k2 v)) (less a share >= 0, clamped at
// 0) with m = d(C) - t.r >= d(C) - R, R the largest t.r within reach (deon_tsm_max.frag): once
// (d(C) - R)^2 / (k2 v) > TSM_ZERO, exp underflows to exactly 0 in float32 (below the smallest
// denormal past 103.97; flushed past 87.3), so the skip returns what the loops would: bit for bit.
#ifndef TSM_SKIP
#define TSM_SKIP 0
#endif
#ifndef TSM_TAPS_NARROW
#define TSM_TAPS_NARROW 1  // the 3x3 taps' terms only for the Gaussians not gathered (the others' f[i] is unread)
#endif
#ifndef TSM_TAPS_SKIP
#define TSM_TAPS_SKIP 1  // a Gaussian's taps skipped where m_near proves them 0 (TSM_SKIP's bound, per Gaussian)
#endif
#ifndef TSM_MAX_CHANNELS
#define TSM_MAX_CHANNELS 4  // the max map's channels read (1: R alone, the widest reach's bound: session 8's skip)
#endif
#ifndef TSM_ZERO
#define TSM_ZERO 110.0  // exact: every exp past it is 0 in float32; passes.deon.TSM_CUT sets 16.64 (< 2^-24)
#endif
#ifndef TSM_PROBE
#define TSM_PROBE 0  // measurement only (benchmarks/bench_transmitted_parts.py): 1 no gather, 2 no tap terms, 4 setup only
#endif
#ifndef TSM_SKIP_MARK
#define TSM_SKIP_MARK 0.0  // what a skipped texel returns: -1 marks it (the share skipped, benchmarks)
#endif
#if TSM_SKIP
uniform sampler2D tsm_max_map;  // deon_tsm_max: the largest t.r around each block of TSM texels, 4 reaches
uniform int u_tsm_max_block;    // TSM texels per block side
uniform vec4 u_tsm_max_reach;   // TSM texels each channel's max reaches past C's texel on each side
#endif
#if TSM_GATHER_N > 0
uniform float u_tsm_map_mm;       // the TSM's width in mm (light space; a point light's at the subject)
uniform sampler2D irradiance_map; // E of the lit points the gather reaches (eq. 28)

// Gaussian i's light-space gather at C (c: C's TSM coordinates, dC its distance, sC its UV per mm); the
// spiral turned by `turn` (pi/4 per Gaussian: each one's samples take other directions, so their
// errors on an edge in the TSM do not add up).
// m_near > 0: no sample's m is below it (TSM_SKIP), so when its term underflows every term is 0.
vec3 tsm_gathered(float v, float turn, vec2 c, float dC, vec2 uvC, vec2 sC, float zoneC, float k2, float m_near) {
    if (m_near > 0.0 && m_near * m_near > TSM_ZERO * k2 * v) return vec3(0.0);  // exactly the loop's 0
#if (TSM_PROBE & 1) != 0
    return vec3(0.0);
#endif
    float sig = sqrt(0.5 * k2 * v);  // samples ~ exp(-lat^2 / (k2 v))
    vec3 e = vec3(0.0);
    for (int k = 0; k < TSM_GATHER_N; ++k) {
        float rad = sig * sqrt(-2.0 * log(1.0 - (float(k) + 0.5) / float(TSM_GATHER_N)));
        float th = float(k) * 2.39996323 + turn;  // the golden angle
        vec2 o = rad * vec2(cos(th), sin(th));  // mm in the light's plane
        vec4 t = texture(tsm_map, c + o / u_tsm_map_mm);
        float m = finite_f32(dC - t.r);
        vec2 duv = (uvC - t.gb) / sC;  // the surface blur's share: A in C's island only (as below)
        float carried = (abs(uv_zone(zone_map, t.gb) - zoneC) < 0.5) ? exp(-max(dot(duv, duv) - dot(o, o), 0.0) / (k2 * v)) : 0.0;
        float term = max(exp(-m * m / (k2 * v)) - carried, 0.0);
        vec3 E = texture(irradiance_map, t.gb).rgb / clamp(t.a, 0.05, 1.0);
        e += (t.a < 0.0) ? vec3(0.0) : term * E;
    }
    return e / float(TSM_GATHER_N);
}
#endif
// N: C's (vertex) normal; facing away from the light, C is not lit whatever the TSM's depth says.
vec3 tsm_transmitted(vec3 P, vec3 N, vec2 uvC) {
    vec4 p = u_tsm_matrix * vec4(P, 1.0);
    if ((isnan(p.w) || p.w <= 0.0)) return vec3(0.0);
    vec2 c = p.xy / p.w * 0.5 + 0.5;
    if (any(lessThan(c, vec2(0.0))) || any(greaterThan(c, vec2(1.0)))) return vec3(0.0);
    vec4 t0 = texture(tsm_map, c);
    if (t0.a < 0.0) return vec3(0.0);  // no surface towards the light
    vec2 texel = 1.0 / vec2(textureSize(tsm_map, 0));
    float dC = tsm_distance_mm(P);
    float k2 = (u_tsm_printed != 0) ? 1.0 : 2.0;  // eq. 33 as printed: exp(-x^2 / v)
    // mn[i]: Gaussian i's m_near, no read of its terms has a smaller m (<= 0: no bound, no skip)
    float mn[MAX_GAUSSIANS];
    for (int i = 0; i < MAX_GAUSSIANS; ++i) mn[i] = -1.0;
#if TSM_SKIP
    {   // each used Gaussian's reach (its gather's last spiral sample, the 3x3 taps else) and the tightest
        // channel of the max map that covers it (+2 texels for rounding); a max map of this TSM's size only
        ivec2 nT = textureSize(tsm_map, 0);
        if (textureSize(tsm_max_map, 0) == (nT + u_tsm_max_block - 1) / u_tsm_max_block) {
            ivec2 q = clamp(ivec2(floor(c * vec2(nT))), ivec2(0), nT - ivec2(1));
            vec4 R4 = texelFetch(tsm_max_map, q / u_tsm_max_block, 0);
#if TSM_GATHER_N > 0
            float tmm = u_tsm_map_mm * texel.x;
#endif
            bool zero = true;  // every used Gaussian's every term underflows: 0 before the loops
            for (int i = 0; i < MAX_GAUSSIANS; ++i) {
                if (i >= u_count) break;
                float v = u_var[i];
                if (((G_MASK >> i) & 1) == 0 || u_used[i] == 0 || !(v > 0.0)) continue;
                float reach = 1.0;
#if TSM_GATHER_N > 0
                if (v > 4.0 * tmm * tmm)
                    reach = max(reach, sqrt(0.5 * k2 * v) * sqrt(2.0 * log(2.0 * float(TSM_GATHER_N))) / tmm);
#endif
                float R = FLOAT_MAX;
                bool covered = false;
                for (int ch = 0; ch < TSM_MAX_CHANNELS; ++ch)
                    if (reach + 2.0 <= u_tsm_max_reach[ch]) { R = min(R, R4[ch]); covered = true; }
                if (covered) mn[i] = dC - R;
                if (!(mn[i] > 0.0 && mn[i] * mn[i] > TSM_ZERO * k2 * v)) zero = false;
            }
            if (zero) return vec3(TSM_SKIP_MARK);
        }
    }
#endif
#if (TSM_PROBE & 4) != 0
    return vec3(mn[0]);
#endif
#if TSM_GATHER_N > 0
    float texel_mm = u_tsm_map_mm * texel.x;  // a Gaussian wider than two TSM texels is gathered
#endif
    // live[i]: Gaussian i's tap terms can be non-zero. Every tap reads a t.r <= the max map's R, so
    // m >= m_near; past TSM_ZERO its exp(-m^2 / (k2 v)) underflows to 0 at every tap and the term,
    // max(0 - exp(-r^2 / (k2 v)), 0), is exactly +0: skipping it adds what the loop adds (TSM_TAPS_SKIP).
    bool live[MAX_GAUSSIANS];
    bool taps_live = false;  // some Gaussian's tap terms are live: r (zone, stretch) and the blurs are read
    for (int i = 0; i < MAX_GAUSSIANS; ++i) {
        float v = u_var[i];
        live[i] = i < u_count && ((G_MASK >> i) & 1) != 0 && u_used[i] != 0 && !(isnan(v) || v <= 0.0);
#if TSM_GATHER_N > 0 && TSM_TAPS_NARROW
        if (v > 4.0 * texel_mm * texel_mm) live[i] = false;  // gathered below: f[i] is not read (a uniform branch)
#endif
#if TSM_TAPS_SKIP
        if (mn[i] > 0.0 && mn[i] * mn[i] > TSM_ZERO * k2 * v) live[i] = false;
#endif
        taps_live = taps_live || live[i];
    }
    vec2 s = taps_live ? 0.5 * (uv_per_mm(uvC) + uv_per_mm(t0.gb)) : vec2(1.0);
    float zoneC = uv_zone(zone_map, uvC);
    vec3 Lc = (u_tsm_kind == LIGHT_POINT) ? normalize(u_tsm_pos - P) : u_tsm_dir;
    float away = smoothstep(0.0, 0.2, -dot(N, Lc) * inversesqrt(max(dot(N, N), 1e-30)));
    float f[MAX_GAUSSIANS];
    for (int i = 0; i < MAX_GAUSSIANS; ++i) f[i] = 0.0;
    bool any_k = false;
    float g0 = 0.0;  // how far C is behind the first surface (0: C is lit itself)
    for (int y = -1; y <= 1; ++y) for (int x = -1; x <= 1; ++x) {
        vec4 t = texture(tsm_map, c + vec2(x, y) * texel);
        if (t.a < 0.0) continue;
        float m = finite_f32(dC - t.r);
        float cosA = clamp(t.a, 0.05, 1.0);
        float tol = u_tsm_gate_mm * (1.0 + 0.5 * sqrt(1.0 - cosA * cosA) / cosA);
        g0 += max(smoothstep(tol, 2.0 * tol, m), m > 0.0 ? away : 0.0) / 9.0;
        float g = smoothstep(tol, 2.0 * tol, m);
        if ((isnan(g) || g <= 0.0)) continue;
        any_k = true;
#if (TSM_PROBE & 2) != 0
        continue;
#endif
        if (!taps_live) continue;
        float r = (abs(uv_zone(zone_map, t.gb) - zoneC) < 0.5) ? length((uvC - t.gb) / s) : 1e18;
        for (int i = 0; i < MAX_GAUSSIANS; ++i) {
            if (i >= u_count) break;
            float v = u_var[i];
            if (!live[i]) continue;
            f[i] += g * max(exp(-m * m / (k2 * v)) - exp(-r * r / (k2 * v)), 0.0);
        }
    }
    if (!any_k && (isnan(g0) || g0 <= 0.0)) return vec3(0.0);
    vec4 there[MAX_GAUSSIANS];
    for (int i = 0; i < MAX_GAUSSIANS; ++i) there[i] = vec4(0.0);
    if (taps_live) {  // else every f[i] read below is 0 and the blurs (finite) are not needed
        FETCH_BLURS(there, t0.gb, THERE_MASK)
    }
    vec3 acc = vec3(0.0);
#if TSM_GATHER_N > 0
    vec2 sC = uv_per_mm(uvC);
#endif
#if (TSM_PROBE & 8) != 0
    // Gaussians gathered (past their own skip), of them non-zero; 1 reached here, 2 with tap terms live
    vec3 cnt = vec3(0.0, 0.0, taps_live ? 2.0 : 1.0);
#endif
    for (int i = 0; i < MAX_GAUSSIANS; ++i) {
        if (i >= u_count) break;
        if (((G_MASK >> i) & 1) == 0 || u_used[i] == 0) continue;
#if TSM_GATHER_N > 0
        if (u_var[i] > 4.0 * texel_mm * texel_mm) {  // a uniform branch
#if (TSM_PROBE & 8) != 0
            vec3 e = tsm_gathered(u_var[i], float(i) * 0.78539816, c, dC, uvC, sC, zoneC, k2, mn[i]);
            cnt.x += (mn[i] > 0.0 && mn[i] * mn[i] > TSM_ZERO * k2 * u_var[i]) ? 0.0 : 1.0;
            cnt.y += any(notEqual(u_w[i] * g0 * e, vec3(0.0))) ? 1.0 : 0.0;
#endif
            acc += u_w[i] * g0 * tsm_gathered(u_var[i], float(i) * 0.78539816, c, dC, uvC, sC, zoneC, k2, mn[i]);
        } else
#endif
            acc += u_w[i] * (f[i] / 9.0) * there[i].rgb;
    }
#if (TSM_PROBE & 8) != 0
    return cnt;
#endif
    return acc;
}
#endif
