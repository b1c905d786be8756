#version 330 core
#pragma vertex_stage "vs/camera_curvature.vert"
// Pre-integrated skin (Penner & Borshukov, GPU Pro 2, 2011; physics/penner.py):
//   diffuse  = C rho_dt(N.V) sum_i Lc_i rho_dt(N.L_i) D(N.L_i, k) P(s_i, W_i)
//   specular = sum_i Lc_i KS_i s_i                                  (seed 000 eq. 14-16, 35)
// D: the profile integrated around a ring of curvature k (ring_lut: rows k / k_max, columns N.L);
// P: the PCF shadow value s across a penumbra of width W mm, diffused by the profile
// (penumbra_lut: rows W / W_max, columns s); s = 0 and s = 1 stay exact.
// An environment light: its SH irradiance with each band scaled by D's Funk-Hecke weight at k
// (penner_env_bands, physics/penner.env_band_factors): the environment scattered around the ring too.
// PENNER_TR: Jimenez 2010's transmittance through thin parts (seed 001 eq. 3.15, 3.18; spec §6.2), as
// the screen-space techniques shade it: per shadow-casting light Lc back (n/9) T(d x scale), d the
// shadow map's thickness (lib/tr_thickness.glsl), T the profile in use (lib/tr_profile.glsl); with an
// environment bake, its back-side irradiance at the baked thickness along -N (issue 32).
#include "lib/color.glsl"
#include "lib/lights.glsl"
#include "lib/surface.glsl"
#include "lib/specular_params.glsl"
#include "lib/environment.glsl"
#ifndef PENNER_TR
#define PENNER_TR 0
#endif
#if PENNER_TR
#include "lib/tr_thickness.glsl"
#include "lib/tr_profile.glsl"
uniform float u_tr_wrap;
#endif
in vec3 v_position;
in vec3 v_normal;
in vec2 v_uv;
in vec4 v_tangent;
in float v_curvature;
uniform vec3 u_eye;
uniform sampler2D ring_lut;
uniform sampler2D penumbra_lut;
uniform sampler2D penner_env_bands;  // the environment's SH band weights per curvature (ENV_LIGHT)
uniform sampler2D rho_dt_tex;
uniform int u_energy;
uniform int u_penumbra;
uniform float u_curvature_scale;   // penner.curvature_scale / penner.max_curvature
uniform float u_penumbra_scale;    // mm per mesh unit / penner.penumbra_max_mm
uniform float u_penumbra_texels;   // PCF box width in shadow-map texels
out vec4 f_color;

void main() {
    set_light_footprint(dFdx(v_position), dFdy(v_position));  // beam lights: area coverage
    vec3 N = surface_normal(v_normal, v_tangent, v_uv);
    vec3 V = ks_safe_normalize(u_eye - v_position);
    vec3 Ng = normalize(v_normal);
    if (!gl_FrontFacing) { N = -N; Ng = -Ng; }  // the back of an open sheet (scene.back_faces: show)
    vec3 C = max(finite3(texture(albedo_map, v_uv).rgb), vec3(0.0));
    SpecParams sp = specular_params(v_uv);
    float k = clamp(max(v_curvature, 0.0) * u_curvature_scale, 0.0, 1.0);
    vec3 diffuse = vec3(0.0);
    vec3 spec = vec3(0.0);
    for (int i = 0; i < N_LIGHTS; ++i) {
        vec3 L;
        vec3 Lc = light_incident(i, v_position, L);
        float ndl = dot(N, L);
#if PENNER_TR
        if (u_light_shadowed[i] != 0) {
            // eq. 3.15 with [SEP]'s wrap: back-side irradiance through the inverted vertex normal
            float back = clamp(u_tr_wrap + dot(L, -Ng), 0.0, 1.0);
            vec2 t = back > 0.0 ? transmitted(i, v_position, Ng) : vec2(0.0);
            if (t.x > 0.0) diffuse += Lc * (back * t.x) * transmittance_profile(t.y * u_tr_scale);
        }
#endif
        vec3 D = texture(ring_lut, vec2(clamp(ndl * 0.5 + 0.5, 0.0, 1.0), k)).rgb;
        if ((isnan(max(D.r, max(D.g, D.b))) || max(D.r, max(D.g, D.b)) <= 0.0)) continue;
        float s = shadow_factor(i, v_position, normalize(v_normal));
        vec3 P = vec3(s);
        if (u_penumbra != 0 && s > 0.0 && s < 1.0) {
            float w = clamp(u_shadow_texel[i] * u_penumbra_texels * u_penumbra_scale, 0.0, 1.0);
            P = texture(penumbra_lut, vec2(s, w)).rgb;
        }
        float rho = (u_energy != 0) ? surface_rho_dt(rho_dt_tex, max(ndl, 0.0), sp) : 1.0;  // eq. (32)
        diffuse += Lc * rho * D * P;
        if (ndl > 0.0) spec += Lc * (surface_ks(N, L, V, sp) * s);
    }
#if ENV_LIGHT
    ENV_VIS_IN();
    // the ring table's band weights at this curvature (columns: bands 0, 1, 2; rows as ring_lut)
    vec3 w0 = texture(penner_env_bands, vec2(0.5 / 3.0, k)).rgb, w1 = texture(penner_env_bands, vec2(0.5, k)).rgb,
         w2 = texture(penner_env_bands, vec2(2.5 / 3.0, k)).rgb;
    diffuse += env_irradiance_scattered(N, v_normal, w0, w1, w2)
             * ((u_energy != 0) ? env_rho_dt_mean(rho_dt_tex, sp) : 1.0);
    spec += env_specular(N, V, v_normal, sp);
#if PENNER_TR && ENV_RAYS > 0
    diffuse += env_back_irradiance(Ng) * transmittance_profile(ENV_THICK().x * u_mm_per_unit * u_tr_scale);
#endif
#endif
    float rho_v = (u_energy != 0) ? surface_rho_dt(rho_dt_tex, dot(N, V), sp) : 1.0;  // eq. (34)
    f_color = vec4(finite3(C * rho_v * diffuse + spec), 1.0);
}
