// Irradiance in texture space (seed 000 eq. 28, 32) at one texel's surface point: the body of
// deon_irradiance.frag (mesh unwrapped) and deon_irradiance_texels.frag (full-screen over the texel
// surface map, one fragment per texel), so both compute the same values from the same inputs.
//   E = sum over lights of Lc (N.L) fac_shadow rho_dt(x, L) C^mix
// and, in alpha, the thickness d = (d(C) - d(A)) cos(theta) in mm read from the modified TSM
// (§4.2.7), so the blur chain blurs it with the irradiance. float32 target: lights beyond the
// half-float range stay finite and exact.
#ifndef SKINVIEWER_DEON_IRRADIANCE_GLSL
#define SKINVIEWER_DEON_IRRADIANCE_GLSL
#include "lib/color.glsl"
#include "lib/lights.glsl"
#include "lib/surface.glsl"
#include "lib/specular_params.glsl"
#include "lib/deon.glsl"
#include "lib/environment.glsl"
uniform float u_mix;
uniform int u_energy;            // eq. (32) on/off
uniform sampler2D rho_dt_tex;
uniform int u_tsm;
uniform sampler2D tsm_map;
uniform mat4 u_tsm_matrix;
uniform float u_max_thickness;   // mm
// The split irradiance (issue 27; notes/deon_light_move.md section 9). DEON_SURFACE = 1: the
// light-independent pass (deon_irradiance_surface.frag) writes what eq. (28)/(32) need of the texel and
// not of the light, as exact float32: the shading normal N and m, C^mix and rho_s, and with the
// environment its occluded irradiance and rho_dt's hemispherical mean. DEON_CACHED = 1: the light pass
// reads them at its own texel instead of fetching the maps; the arithmetic, and its order
// E = (sum over lights + env) C, is the one-pass shader's, so the result is the same to the bit.
#ifndef DEON_SURFACE
#define DEON_SURFACE 0
#endif
#ifndef DEON_CACHED
#define DEON_CACHED 0
#endif
#ifndef DEON_CACHED_ENV
#define DEON_CACHED_ENV 0
#endif
#if DEON_CACHED
uniform sampler2D irr_surface0;  // N, m
uniform sampler2D irr_surface1;  // C^mix, rho_s
#if DEON_CACHED_ENV
uniform sampler2D irr_surface2;  // the environment's occluded irradiance at N, rho_dt's hemispherical mean
#endif
#endif
#if DEON_SURFACE
layout(location = 0) out vec4 f_surface0;
layout(location = 1) out vec4 f_surface1;
#if ENV_LIGHT
layout(location = 2) out vec4 f_surface2;
#endif
#else
layout(location = 0) out vec4 f_irradiance;
#endif
#ifndef DEON_VISIBILITY
#define DEON_VISIBILITY 0
#endif
#if DEON_VISIBILITY
// fac_shadow of each light slot (eq. 10) where it lights the texel (N.L > 0), else 0: the final pass's
// specular reads it instead of testing the shadow maps per pixel (deon.specular_shadows = texture)
layout(location = 1) out vec4 f_visibility;
#endif
// P, Nv, uv, T: the interpolated vertex position, normal, UV and tangent at the texel centre;
// dPdx, dPdy: the position's change per texel step (beam footprints)
// deon.texel_samples = 4 (issue 30 item 4): the shadow test and N.L averaged over the texel's surface
// patch at a rotated 2 x 2 grid (offsets in texels; P moves along dPdx, dPdy, the normal map is read at
// the sample's uv), so a texel a shadow edge crosses carries its lit fraction as the ground truth's
// integral over the surface does, instead of all or nothing at its centre. Each sample is the hard eq. (7)
// test at its own sub-texel position in the shadow map (lights.glsl shadow_hard): the PCF on top widened the penumbra past the texel (against the judge that shares no shadow, the
// scan at 512^2: green / blue p99 5.2 / 3.6 % with the PCF, 3.7 / 1.7 % without; notes/truth.md item 4).
uniform int u_texel_samples;
uniform vec2 u_texel_uv;          // 1 / the irradiance map's size
const vec2 TEXEL_SAMPLE[4] = vec2[4](vec2(-0.375, -0.125), vec2(0.125, -0.375), vec2(0.375, 0.125),
                                     vec2(-0.125, 0.375));

#if !DEON_SURFACE
void deon_irradiance(vec3 v_position, vec3 v_normal, vec2 v_uv, vec4 v_tangent, vec3 dPdx, vec3 dPdy) {
    set_light_footprint(dPdx, dPdy);  // beam lights: area coverage
#if DEON_CACHED
    // the light-independent pass's values at this texel (DEON_SURFACE above)
    ivec2 q = ivec2(gl_FragCoord.xy);
    vec4 s0 = texelFetch(irr_surface0, q, 0), s1 = texelFetch(irr_surface1, q, 0);
    vec3 N = s0.xyz;
    vec3 C = s1.rgb;
    vec3 E = vec3(0.0);
    SpecParams sp = SpecParams(s0.w, s1.w);
#else
    g_surface_footprint = u_texel_uv;  // one texel of this map: the same mip level on either path
    vec3 N = surface_normal(v_normal, v_tangent, v_uv);
    vec3 C = safe_pow(surface_map(albedo_map, v_uv).rgb, u_mix);
    vec3 E = vec3(0.0);
    SpecParams sp = specular_params(v_uv);
#endif
    vec4 vis = vec4(0.0);
#if DEON_CACHED
    const int ns = 1;  // the light pass runs only with one sample (4 read the normal map at other uv)
#elif defined(DEON_TEXEL_SAMPLES) && DEON_TEXEL_SAMPLES > 0 && !defined(GENERIC_SHADERS)
    // the pass compiles deon.texel_samples in (issue 27): llvmpipe runs both sides of a branch on a
    // uniform under a mask, so the 4-sample path cost the 1-sample default 10-20 % of this pass
    const int ns = (DEON_TEXEL_SAMPLES >= 4) ? 4 : 1;
#else
    int ns = (u_texel_samples >= 4) ? 4 : 1;
#endif
    vec2 duv = u_texel_uv;  // one texel of the irradiance map in uv
    for (int i = 0; i < N_LIGHTS; ++i) {
        vec3 L;
        vec3 Lc = light_incident(i, v_position, L);
        if (ns == 1) {
            float ndl = dot(N, L);
            if ((isnan(ndl) || ndl <= 0.0)) continue;
            float s = shadow_factor(i, v_position, normalize(v_normal));
            vis[i] = s;
            float rho = (u_energy != 0) ? surface_rho_dt(rho_dt_tex, ndl, sp) : 1.0;  // eq. (32)
            E += Lc * (ndl * s * rho);
            continue;
        }
        float e = 0.0, sv = 0.0;
        for (int k = 0; k < 4; ++k) {
            vec2 o = TEXEL_SAMPLE[k];
            vec3 Pk = v_position + dPdx * o.x + dPdy * o.y;
            vec3 Lk;
            light_incident(i, Pk, Lk);
            float ndl = dot(surface_normal(v_normal, v_tangent, v_uv + o * duv), Lk);
            if ((isnan(ndl) || ndl <= 0.0)) continue;
            float s = shadow_factor_test(i, Pk, normalize(v_normal), true);  // the four samples are the filter
            sv += s;
            float rho = (u_energy != 0) ? surface_rho_dt(rho_dt_tex, ndl, sp) : 1.0;  // eq. (32)
            e += ndl * s * rho;
        }
        vis[i] = 0.25 * sv;
        E += Lc * (0.25 * e);
    }
#if DEON_CACHED && DEON_CACHED_ENV
    vec4 s2 = texelFetch(irr_surface2, q, 0);
    E += s2.rgb * s2.a;  // the same product as below, its factors made by the light-independent pass
#elif ENV_LIGHT
    // the environment, occluded, with eq. (32)'s rho_dt averaged over the hemisphere
    E += env_irradiance(N, v_normal) * ((u_energy != 0) ? env_rho_dt_mean(rho_dt_tex, sp) : 1.0);
#endif
    E *= C;
    float d = 0.0;
    if (u_tsm != 0) {
        vec4 p = u_tsm_matrix * vec4(v_position, 1.0);
        if (p.w > 0.0) {
            vec2 c = p.xy / p.w * 0.5 + 0.5;
            if (all(greaterThanEqual(c, vec2(0.0))) && all(lessThanEqual(c, vec2(1.0)))) {
                vec4 t = texture(tsm_map, c);
                if (t.a >= 0.0) d = (tsm_distance_mm(v_position) - t.r) * t.a;
            }
        }
    }
    d = clamp(finite_f32(d), 0.0, u_max_thickness);
    f_irradiance = bounded4_f32(vec4(E, d));  // a NaN in E is flagged (render.check_finite), not hidden
#if DEON_VISIBILITY
    f_visibility = vis;
#endif
}
#endif

#if DEON_SURFACE
// the light-independent half of deon_irradiance (issue 27): its first lines and its environment term,
// stored as they are computed (float32 targets: exact); rho_s and m only where eq. (32) reads them
void deon_irradiance_surface(vec3 v_normal, vec2 v_uv, vec4 v_tangent) {
    g_surface_footprint = u_texel_uv;  // one texel of this map: the same mip level on either path
    vec3 N = surface_normal(v_normal, v_tangent, v_uv);
    vec3 C = safe_pow(surface_map(albedo_map, v_uv).rgb, u_mix);
    SpecParams sp = specular_params(v_uv);
    bool energy = u_energy != 0;
    f_surface0 = vec4(N, energy ? sp.m : 0.0);
    f_surface1 = vec4(C, energy ? sp.rho_s : 0.0);
#if ENV_LIGHT
    f_surface2 = vec4(env_irradiance(N, v_normal), energy ? env_rho_dt_mean(rho_dt_tex, sp) : 1.0);
#endif
}
#endif
#endif
