// Lights and shadow lookups shared by every technique (seed 000 §4.1.1-4.1.2).
// Specialisation (skinviewer.passes.common.declare_lighting): a lit program is compiled with
// LIGHT_COUNT, SHADOW_PCF, SHADOW_BILINEAR, SHADOW_MASK (bit k: light slot k has a shadow map) and
// POINT_MASK / BEAM_MASK (bit k: slot k is a point light / a beam) for the frame's lights, so its
// loops have constant bounds and absent shadow lookups and light kinds vanish: a SIMD rasteriser
// pays every tap of a loop that merely `continue`s, and a beam's coverage where no light is a beam. GENERIC_SHADERS (or no LIGHT_COUNT) compiles
// the uniform-driven version; both give bit-identical images (tests/test_specialise.py).
#ifndef SKINVIEWER_LIGHTS_GLSL
#define SKINVIEWER_LIGHTS_GLSL
// The specialised bilinear PCF reads its (2r + 2)^2 taps as (r + 1)^2 textureGather 2 x 2 footprints
// where the GL has it (GLSL 4.00, or ARB_texture_gather: Mesa's llvmpipe at 3.3): the same texels and
// terms in the same order, the same bits, ~10 % less CPU for a lit pass on llvmpipe (issue 27,
// notes/deon_light_move.md section 18). PCF_GATHER=0 reads the taps one texelFetch each (an A/B).
// The shader library moves this #extension after #version (GLSL refuses one after code).
#extension GL_ARB_texture_gather : enable
#if !defined(PCF_GATHER) && (defined(GL_ARB_texture_gather) || __VERSION__ >= 400)
#define PCF_GATHER 1
#endif
#if defined(LIGHT_COUNT) && !defined(GENERIC_SHADERS)
#define LIGHTS_SPECIALISED 1
#define N_LIGHTS LIGHT_COUNT        // loop bound of the lit passes: for (i = 0; i < N_LIGHTS; ...)
#if !defined(POINT_MASK) || !defined(BEAM_MASK)
#error "a specialised lit program needs POINT_MASK and BEAM_MASK (passes.common.declare_lighting)"
#endif
#define LIGHT_IS_POINT(i) (((POINT_MASK >> (i)) & 1) != 0)
#define LIGHT_IS_BEAM(i) (((BEAM_MASK >> (i)) & 1) != 0)
#else
#define N_LIGHTS u_light_count
#define LIGHT_IS_POINT(i) (u_light_kind[i] == LIGHT_POINT)
#define LIGHT_IS_BEAM(i) (u_light_kind[i] == LIGHT_BEAM)
#endif
#include "lib/beam.glsl"
uniform int u_light_count;
uniform int u_light_kind[MAX_LIGHTS];       // LIGHT_DIRECTIONAL, LIGHT_POINT, LIGHT_BEAM
uniform vec3 u_light_radiance[MAX_LIGHTS];  // colour * intensity (Lc)
uniform vec3 u_light_dir[MAX_LIGHTS];       // towards the light (normalised)
uniform vec3 u_light_pos[MAX_LIGHTS];
uniform float u_beam_radius[MAX_LIGHTS];
uniform int u_light_shadowed[MAX_LIGHTS];
uniform mat4 u_light_matrix[MAX_LIGHTS];    // eq. (6), GL clip space
uniform sampler2D shadow_map0;
uniform sampler2D shadow_map1;
uniform sampler2D shadow_map2;
uniform sampler2D shadow_map3;
uniform float u_shadow_tol;                 // eq. (7)
uniform float u_shadow_texel[MAX_LIGHTS];   // world size of one shadow-map texel at the subject
uniform int u_shadow_pcf;
uniform int u_shadow_bilinear;              // shadow.pcf_filter (generic shaders; SHADOW_BILINEAR when specialised)
const float MAX_RECEIVER_SLOPE = 11.43;     // tan 85 deg: the steepest receiver plane followed

// Direction to the light L and incident radiance Lc at world point P (eq. 9).
vec3 light_incident(int i, vec3 P, out vec3 L) {
    vec3 Lc = u_light_radiance[i];
    if (LIGHT_IS_POINT(i)) {
        vec3 d = u_light_pos[i] - P;
        float len2 = max(dot(d, d), 1e-12);
        L = d * inversesqrt(len2);
        return Lc;  // no inverse-square falloff: artists set intensity at the subject
    }
    L = u_light_dir[i];
    if (LIGHT_IS_BEAM(i)) {
        // beam: collimated, radius u_beam_radius around the axis through u_light_pos
        // averaged over the texel/pixel footprint set by set_light_footprint (lib/beam.glsl)
        return Lc * beam_coverage(P, u_light_pos[i], L, u_beam_radius[i]);
    }
    return Lc;
}

// The eq. (7) test against shadow-map texel q (clamped to the map), the receiver's depth taken on its
// plane at that texel's centre: z + g . (centre - c.xy) (receiver-plane depth bias: a tilted receiver
// does not shadow itself across the PCF footprint).
float shadow_test(sampler2D sm, ivec2 q, vec3 c, vec2 g) {
    ivec2 size = textureSize(sm, 0);
    float z = c.z + dot(g, (vec2(q) + 0.5) / vec2(size) - c.xy);
    q = clamp(q, ivec2(0), size - 1);
    return (z - texelFetch(sm, q, 0).r > u_shadow_tol) ? 0.0 : 1.0;
}

// shadow_test with the map's depth ds at q already read (PCF_GATHER)
float shadow_tested(ivec2 q, ivec2 size, vec3 c, vec2 g, float ds) {
    float z = c.z + dot(g, (vec2(q) + 0.5) / vec2(size) - c.xy);
    return (z - ds > u_shadow_tol) ? 0.0 : 1.0;
}

// PCF weight of the tap at offset k (-r .. r + 1) along one axis: a (2r + 1)-texel box slid by the
// sub-texel position t of the lookup, so the filtered visibility varies continuously with position
// (bilinear PCF) instead of in steps of one texel (the terraces of a shadow edge).
float pcf_weight(int k, int r, float t) {
    return (k == -r) ? 1.0 - t : ((k == r + 1) ? t : 1.0);
}

// SHADOW_BOUNDS (issue 27; passes.shadow_map.ShadowBoundsPass, shaders/shadow_bounds.frag): the exact
// early-out of the specialised PCF (shadow.pcf >= 1). The bounds map holds, per block of the shadow map,
// a plane P'(u) = a' + G . (u - u_b) under every depth of the texels a lookup from that block reads, and
// the span s above it. Every tap compares z = c.z + g . d (the receiver plane, d its centre's offset from
// c) with ds in [P', P' + s], so with K = c.z - P'(c):
//   z - ds <= K + (g - G) . d                 (every test 1 when this is <= tol for every tap: lit)
//   z - ds >= K + (g - G) . d - |G| . e - s   (every test 0 when this is > tol for every tap: shadowed)
// (g - G) . d bounded over the taps' box (bilinear: x - t texels, x = -r .. r + 1; box: x = -r .. r, and
// e = 1 texel: the texel a nearest lookup reads is within it of its point). A margin covers float32's
// rounding on both sides (~1e-7 relative; 1e-5 taken). A decided lookup returns what the taps return: 0
// (every term 0), or for the bilinear filter the same weights summed in the same order times a runtime
// 1.0 (the same products, fused or not). The taps are a loop of (2r + 2)^2 iterations, or none: llvmpipe
// runs both sides of an if under a mask, and leaves a loop after one masked iteration when no lane is left.
#if defined(LIGHTS_SPECIALISED) && defined(SHADOW_BOUNDS) && SHADOW_BOUNDS != 0 && SHADOW_PCF > 0
#ifndef SHADOW_BOUNDS_BLOCK
#define SHADOW_BOUNDS_BLOCK 8
#endif
#define PCF_BOUNDED 1
uniform sampler2D shadow_bounds0;
uniform sampler2D shadow_bounds1;
uniform sampler2D shadow_bounds2;
uniform sampler2D shadow_bounds3;
// 1: every tap lit, 0: every tap shadowed, -1: not decided (the taps are read)
float shadow_decided(sampler2D sm, sampler2D sb, vec3 c, vec2 g) {
    ivec2 size = textureSize(sm, 0);
    vec2 fs = vec2(size);
    ivec2 nb = textureSize(sb, 0);
    ivec2 b = clamp(ivec2(floor(c.xy * fs)) / SHADOW_BOUNDS_BLOCK, ivec2(0), nb - 1);
    vec4 pb = texelFetch(sb, b, 0);  // a', G, s
    vec2 ub = (vec2(b * SHADOW_BOUNDS_BLOCK) + 0.5 * float(SHADOW_BOUNDS_BLOCK)) / fs;
    vec2 G = pb.yz, aG = abs(G), e = g - G;
    float K = c.z - pb.x - dot(G, c.xy - ub);
    float margin = 1e-5 * (1.0 + abs(c.z) + abs(pb.x) + (aG.x + aG.y + abs(g.x) + abs(g.y))
                           * float(3 * SHADOW_BOUNDS_BLOCK + 8) / fs.x);
#if defined(SHADOW_BILINEAR) && SHADOW_BILINEAR != 0
    vec2 f = c.xy * fs - 0.5;
    vec2 t = f - floor(f);  // as shadow_compare computes it; 1/64 texel of its rounding below
    vec2 dlo = (-float(SHADOW_PCF) - t - 1.0 / 64.0) / fs, dhi = (float(SHADOW_PCF) + 1.0 - t + 1.0 / 64.0) / fs;
    float slack = 0.0;
#else
    vec2 dlo = vec2(-float(SHADOW_PCF)) / fs, dhi = vec2(float(SHADOW_PCF)) / fs;
    float slack = (aG.x + aG.y) / fs.x;
#endif
    vec2 emax = max(e * dlo, e * dhi), emin = min(e * dlo, e * dhi);
    if (!(pb.w >= 0.0) || size.x != size.y) return -1.0;  // a block at the map's edge: clamped reads
    if (K + emax.x + emax.y + slack + margin <= u_shadow_tol) return 1.0;
    if (K + emin.x + emin.y - slack - pb.w - margin > u_shadow_tol) return 0.0;
    return -1.0;
}
#endif

// The specialised test with `decided` (shadow_decided: 1 lit, 0 shadowed, -1 read the taps; -1 without
// the bounds); the generic shaders read the taps.
float shadow_compare_bounded(sampler2D sm, vec3 c, vec2 g, float decided) {
#ifdef LIGHTS_SPECIALISED
    bool read = decided < 0.0;
    float one = decided;  // a decided lookup's every test (1.0 or 0.0)
#if SHADOW_PCF <= 0
    return (c.z - texture(sm, c.xy).r > u_shadow_tol) ? 0.0 : 1.0;
#elif defined(SHADOW_BILINEAR) && SHADOW_BILINEAR != 0
    const int r = SHADOW_PCF;
    vec2 f = c.xy * vec2(textureSize(sm, 0)) - 0.5;
    vec2 i0 = floor(f), t = f - i0;
    float lit = 0.0;
    if (!read) {  // the taps' sum with every test `one`
        for (int y = -SHADOW_PCF; y <= SHADOW_PCF + 1; ++y) for (int x = -SHADOW_PCF; x <= SHADOW_PCF + 1; ++x)
            lit += pcf_weight(x, r, t.x) * pcf_weight(y, r, t.y) * one;
    }
#ifdef SHADOW_PCF_NESTED  // the loops before (an A/B: bench_deon_draws.py --ab program:SHADOW_PCF_NESTED=1)
    for (int y = -SHADOW_PCF; y <= SHADOW_PCF + 1; ++y) for (int x = -SHADOW_PCF; x <= SHADOW_PCF + 1; ++x)
        lit += pcf_weight(x, r, t.x) * pcf_weight(y, r, t.y) * shadow_test(sm, ivec2(i0) + ivec2(x, y), c, g);
    return lit / float((2 * r + 1) * (2 * r + 1));
#endif
#if defined(PCF_GATHER) && PCF_GATHER != 0
    // the taps' texels as 2 x 2 gathers (textureGather: the bilinear footprint, clamped to the edge as
    // shadow_test clamps), summed y-major in the flat loop's order: the same terms, the same bits
    if (read) {
        ivec2 size = textureSize(sm, 0);
        vec2 inv = 1.0 / vec2(size);
        for (int gy = 0; gy <= SHADOW_PCF; ++gy) {
            int y = 2 * gy - SHADOW_PCF;
            vec4 G[SHADOW_PCF + 1];
            for (int gx = 0; gx <= SHADOW_PCF; ++gx)
                G[gx] = textureGather(sm, (i0 + vec2(2 * gx - SHADOW_PCF, y) + 1.0) * inv);
            for (int gx = 0; gx <= SHADOW_PCF; ++gx) {
                int x = 2 * gx - SHADOW_PCF;
                lit += pcf_weight(x, r, t.x) * pcf_weight(y, r, t.y) * shadow_tested(ivec2(i0) + ivec2(x, y), size, c, g, G[gx].w);
                lit += pcf_weight(x + 1, r, t.x) * pcf_weight(y, r, t.y) * shadow_tested(ivec2(i0) + ivec2(x + 1, y), size, c, g, G[gx].z);
            }
            for (int gx = 0; gx <= SHADOW_PCF; ++gx) {
                int x = 2 * gx - SHADOW_PCF;
                lit += pcf_weight(x, r, t.x) * pcf_weight(y + 1, r, t.y) * shadow_tested(ivec2(i0) + ivec2(x, y + 1), size, c, g, G[gx].x);
                lit += pcf_weight(x + 1, r, t.x) * pcf_weight(y + 1, r, t.y) * shadow_tested(ivec2(i0) + ivec2(x + 1, y + 1), size, c, g, G[gx].y);
            }
        }
    }
    return (!read && one == 0.0) ? 0.0 : lit / float((2 * r + 1) * (2 * r + 1));
#endif
    // one flat loop over the taps, y-major as the nested loops were: the same terms in the same order,
    // and ~13 % less CPU for d'Eon's irradiance light pass on llvmpipe than the two nested loops
    // (notes/deon_light_move.md section 13), the early-out off
    const int side = 2 * SHADOW_PCF + 2;
    int taps = read ? side * side : 0;
    for (int k = 0; k < taps; ++k) {
        int y = k / side - SHADOW_PCF, x = k - (k / side) * side - SHADOW_PCF;
        lit += pcf_weight(x, r, t.x) * pcf_weight(y, r, t.y) * shadow_test(sm, ivec2(i0) + ivec2(x, y), c, g);
    }
    // decided shadowed: +0.0 as the taps' sum is (the weighted sum of zeros can come out -0.0 as compiled)
    return (!read && one == 0.0) ? 0.0 : lit / float((2 * r + 1) * (2 * r + 1));
#else
    vec2 texel = 1.0 / vec2(textureSize(sm, 0));
    float lit = read ? 0.0 : one, n = read ? 0.0 : 1.0;  // decided: every test `one`, lit / n = one exactly
    const int side = 2 * SHADOW_PCF + 1;
    int taps = read ? side * side : 0;
    for (int k = 0; k < taps; ++k) {
        int y = k / side - SHADOW_PCF, x = k - (k / side) * side - SHADOW_PCF;
        float ds = texture(sm, c.xy + vec2(x, y) * texel).r;
        lit += (c.z + dot(g, vec2(x, y) * texel) - ds > u_shadow_tol) ? 0.0 : 1.0;
        n += 1.0;
    }
    return (!read && one == 0.0) ? 0.0 : lit / n;
#endif
#else
    int r = u_shadow_pcf;
    if (r <= 0) return (c.z - texture(sm, c.xy).r > u_shadow_tol) ? 0.0 : 1.0;
    float lit = 0.0;
    if (u_shadow_bilinear != 0) {
        vec2 f = c.xy * vec2(textureSize(sm, 0)) - 0.5;
        vec2 i0 = floor(f), t = f - i0;
        for (int y = -MAX_PCF; y <= MAX_PCF + 1; ++y) for (int x = -MAX_PCF; x <= MAX_PCF + 1; ++x) {
            if (x < -r || x > r + 1 || y < -r || y > r + 1) continue;
            lit += pcf_weight(x, r, t.x) * pcf_weight(y, r, t.y) * shadow_test(sm, ivec2(i0) + ivec2(x, y), c, g);
        }
        return lit / float((2 * r + 1) * (2 * r + 1));
    }
    vec2 texel = 1.0 / vec2(textureSize(sm, 0));
    float n = 0.0;
    for (int y = -MAX_PCF; y <= MAX_PCF; ++y) for (int x = -MAX_PCF; x <= MAX_PCF; ++x) {
        if (abs(x) > r || abs(y) > r) continue;
        float ds = texture(sm, c.xy + vec2(x, y) * texel).r;
        lit += (c.z + dot(g, vec2(x, y) * texel) - ds > u_shadow_tol) ? 0.0 : 1.0;
        n += 1.0;
    }
    return lit / n;
#endif
}

float shadow_compare(sampler2D sm, vec3 c, vec2 g) {
    // eq. (7): shadowed if d(P) - ds > tol; PCF averages the test over a (2 pcf + 1)^2-texel box.
    // shadow.pcf_filter = bilinear: the box slides with the lookup's sub-texel position (the
    // (2 pcf + 2)^2 texels it touches, edge ones weighted by their overlap), so visibility varies
    // continuously instead of in one-texel terraces; box: the box snapped to texels.
    // pcf = 0: the printed hard test at one texel.
    return shadow_compare_bounded(sm, c, g, -1.0);
}

// fac_shadow of eq. (10): 1 lit, 0 shadowed (fractional with PCF). Ng is the geometric normal:
// the lookup point moves off the surface by half a shadow texel to one (normal offset), and each PCF
// tap compares the map with the receiver's tangent plane at that tap (receiver-plane depth bias):
// together they remove self-shadowing acne without the large offset that slid grazing lookups
// sideways past an occluder's silhouette (light in creases).
// the hard eq. (7) test of one sample of deon.texel_samples 4, whatever the PCF radius: at the lookup's
// sub-texel position (the 2 x 2 texels around it weighted bilinearly: a one-texel box slid, pcf_weight
// with r = 0), each texel against the receiver's plane as a PCF tap is. The nearest texel's test alone
// snapped all four samples of a texel to the shadow map's grid: the texel's lit fraction stalled, then
// jumped, as a shadow edge moved across it (issue 30 item 4, notes/truth.md session 12).
float shadow_hard(sampler2D sm, vec3 c, vec2 g) {
    vec2 f = c.xy * vec2(textureSize(sm, 0)) - 0.5;
    vec2 i0 = floor(f), t = f - i0;
    float lit = 0.0;
    for (int k = 0; k < 4; ++k) {
        int x = k & 1, y = k >> 1;
        lit += pcf_weight(x, 0, t.x) * pcf_weight(y, 0, t.y) * shadow_test(sm, ivec2(i0) + ivec2(x, y), c, g);
    }
    return lit;
}

#if defined(PCF_BOUNDED) && defined(SHADOW_BOUNDS_MARK) && SHADOW_BOUNDS_MARK != 0
// benchmarks and tests (passes.common.PCF_BOUNDS_MARK): a decided lookup returns -1 (lit) or -2 (shadowed)
float shadow_marked(float d, float s) { return d >= 0.0 ? -2.0 + d : s; }
#define SHADOW_COMPARE(sm, sb, c, g) shadow_marked(shadow_decided(sm, sb, c, g), shadow_compare(sm, c, g))
#elif defined(PCF_BOUNDED)
#define SHADOW_COMPARE(sm, sb, c, g) shadow_compare_bounded(sm, c, g, shadow_decided(sm, sb, c, g))
#else
#define SHADOW_COMPARE(sm, sb, c, g) shadow_compare(sm, c, g)
#endif
// hard: the eq. (7) hard test (shadow_hard) instead of the PCF (deon.texel_samples 4 averages four of them
// over the texel's patch: a PCF on top would filter the shadow twice, issue 30 item 4)
float shadow_factor_test(int i, vec3 P, vec3 Ng, bool hard) {
#ifdef LIGHTS_SPECIALISED
    if (((SHADOW_MASK >> i) & 1) == 0) return 1.0;
#else
    if (u_light_shadowed[i] == 0) return 1.0;
#endif
    vec3 L = LIGHT_IS_POINT(i) ? normalize(u_light_pos[i] - P) : u_light_dir[i];
    float nl = dot(Ng, L);
    vec3 n = nl >= 0.0 ? Ng : -Ng;
    float sin_l = sqrt(clamp(1.0 - nl * nl, 0.0, 1.0));
    float h = u_shadow_texel[i];
    P += n * h * (0.5 + 0.5 * sin_l);
    vec4 p = u_light_matrix[i] * vec4(P, 1.0);
    if (p.w <= 0.0) return 1.0;
    vec3 c = p.xyz / p.w * 0.5 + 0.5;  // z/w in [0,1] as stored (eq. 6)
    if (any(lessThan(c.xy, vec2(0.0))) || any(greaterThan(c.xy, vec2(1.0)))) return 1.0;
    // the receiver's depth gradient over the map (its tangent plane, two steps of one texel),
    // bounded at a plane 85 degrees from facing the light
    vec3 t1 = normalize(cross(n, abs(n.x) < 0.9 ? vec3(1.0, 0.0, 0.0) : vec3(0.0, 1.0, 0.0)));
    vec3 t2 = cross(n, t1);
    vec4 p1 = u_light_matrix[i] * vec4(P + t1 * h, 1.0), p2 = u_light_matrix[i] * vec4(P + t2 * h, 1.0);
    vec3 d1 = p1.xyz / p1.w * 0.5 + 0.5 - c, d2 = p2.xyz / p2.w * 0.5 + 0.5 - c;
    float det = d1.x * d2.y - d2.x * d1.y;
    vec2 g = (abs(det) > 1e-20) ? vec2(d1.z * d2.y - d2.z * d1.y, d2.z * d1.x - d1.z * d2.x) / det : vec2(0.0);
    vec4 pl = u_light_matrix[i] * vec4(P + L * h, 1.0);
    float z_per_uv = abs(pl.z / pl.w * 0.5 + 0.5 - c.z) / max(length(d1.xy), 1e-20);  // a 45-degree plane's gradient
    float gl = length(g);
    if (gl > MAX_RECEIVER_SLOPE * z_per_uv) g *= MAX_RECEIVER_SLOPE * z_per_uv / gl;
#ifdef LIGHTS_SPECIALISED
#if (SHADOW_MASK & 1) != 0
    if (i == 0) return hard ? shadow_hard(shadow_map0, c, g) : SHADOW_COMPARE(shadow_map0, shadow_bounds0, c, g);
#endif
#if (SHADOW_MASK & 2) != 0
    if (i == 1) return hard ? shadow_hard(shadow_map1, c, g) : SHADOW_COMPARE(shadow_map1, shadow_bounds1, c, g);
#endif
#if (SHADOW_MASK & 4) != 0
    if (i == 2) return hard ? shadow_hard(shadow_map2, c, g) : SHADOW_COMPARE(shadow_map2, shadow_bounds2, c, g);
#endif
#if (SHADOW_MASK & 8) != 0
    if (i == 3) return hard ? shadow_hard(shadow_map3, c, g) : SHADOW_COMPARE(shadow_map3, shadow_bounds3, c, g);
#endif
    return 1.0;
#else
    if (i == 0) return hard ? shadow_hard(shadow_map0, c, g) : shadow_compare(shadow_map0, c, g);
    if (i == 1) return hard ? shadow_hard(shadow_map1, c, g) : shadow_compare(shadow_map1, c, g);
    if (i == 2) return hard ? shadow_hard(shadow_map2, c, g) : shadow_compare(shadow_map2, c, g);
    return hard ? shadow_hard(shadow_map3, c, g) : shadow_compare(shadow_map3, c, g);
#endif
}

float shadow_factor(int i, vec3 P, vec3 Ng) {
    return shadow_factor_test(i, P, Ng, false);
}
#endif
