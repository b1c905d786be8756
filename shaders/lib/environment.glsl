// Environment light (issue 32; numpy twin: skinviewer/physics/environment.py). Compiled in with
// ENV_LIGHT = 1 (skinviewer.passes.environment.declare_environment) when an environment light is on.
//   diffuse:  with occlusion (ENV_RAYS > 0), the vertex's shadowed irradiance sum_lm L_lm T_lm through
//             its baked SH transfer vector (Sloan et al. 2002, bands <= ENV_TRANSFER; ENV_TRANSFER = 0:
//             AO x E_SH at the bent normal), computed in the vertex stage (lib/mesh_vs.glsl), plus the
//             normal map's change of the unoccluded irradiance, AO x (E_SH(N) - E_SH(Nv)); without
//             occlusion E_SH(N) — Ramamoorthi & Hanrahan 2001 eq. 7 (order 2, 9 coefficients A_l L_lm,
//             yaw, colour and intensity applied on the CPU)
//   specular: split sum: the radiance pre-filtered with the Kelemen/Szirmay-Kalos Beckmann lobe
//             (seed 000 eq. 14-16) at R = reflect(-V, N) for the point's m, times the KS specular
//             albedo 1 - rho_dt(N.V) (eq. 30), times specular occlusion (Lagarde & de Rousiers 2014)
// The vertex's (shadowed irradiance rgb, AO w) comes per vertex (lib/mesh_vs.glsl) or from a texel
// surface map (lib/texel_surface.glsl); a pass's main copies it into env_vis (ENV_VIS_IN()).
#if defined(ENV_LIGHT) && ENV_LIGHT && defined(ENV_RAYS) && ENV_RAYS > 0
#if defined(ENV_TEXELS) && ENV_TEXELS
#define ENV_VIS_IN() env_vis = texelFetch(surface_v, ivec2(gl_FragCoord.xy), 0)
#define ENV_THICK() vec2(1e6, 0.0)
#else
in vec4 v_env_vis;
in vec2 v_env_thick;  // lib/mesh_vs.glsl: the thickness along -N (mesh units), the back point's AO
#define ENV_VIS_IN() env_vis = v_env_vis
#define ENV_THICK() v_env_thick
#endif
#else
#define ENV_VIS_IN()
#define ENV_THICK() vec2(1e6, 0.0)
#endif
#ifndef SKINVIEWER_ENVIRONMENT_GLSL
#define SKINVIEWER_ENVIRONMENT_GLSL
#ifndef ENV_LIGHT
#define ENV_LIGHT 0
#endif
#ifndef ENV_RAYS
#define ENV_RAYS 0
#endif
#if ENV_LIGHT
#include "lib/specular_params.glsl"
#include "lib/env_sh.glsl"
#define ENV_LEVELS 7
uniform vec3 u_env_scale;           // colour x intensity of the pre-filtered radiance
uniform vec2 u_env_yaw;             // cos, sin of the environment's yaw
uniform float u_env_level_m[ENV_LEVELS];  // Beckmann m of each pre-filtered level
uniform sampler2D env_prefiltered;  // ENV_LEVELS equirect levels stacked (row 0: the zenith of level 0)
uniform sampler2D env_rho_dt;       // the rho_dt table (eq. 30-31)
// ENV_RAYS > 0 (lights.N.occlusion, the bake's rays): the baked visibility occludes
vec4 env_vis = vec4(0.0, 0.0, 0.0, 1.0);  // the vertex's shadowed irradiance, AO (set by the pass's main)

// the environment's irradiance at shading normal N (vertex normal Nv), occluded
// (physics/environment.env_diffuse_transfer)
vec3 env_irradiance(vec3 N, vec3 Nv) {
#if ENV_RAYS > 0
    return max(env_vis.rgb + env_vis.w * (env_sh_irradiance(N) - env_sh_irradiance(normalize(Nv))), vec3(0.0));
#else
    return env_sh_irradiance(N);
#endif
}

// translucency from the environment (issue 32; physics/environment.env_transmitted): the irradiance the
// back side receives, the SH irradiance at -Ng x the back point's AO (ENV_THICK().y); the caller weights
// it with its transmittance profile at the baked thickness along -N (ENV_THICK().x, mesh units), as its
// lights' back irradiance
vec3 env_back_irradiance(vec3 Ng) {
    return env_sh_irradiance(-Ng) * ENV_THICK().y;
}

// pre-integrated skin's environment term (Penner): the SH irradiance with band l scaled by w_l, the ring
// table's Funk-Hecke band weights at this curvature (physics/penner.env_band_factors), occluded as
// env_irradiance: the vertex's shadowed irradiance plus AO x (scattered E_SH(N) - E_SH(Nv))
vec3 env_irradiance_scattered(vec3 N, vec3 Nv, vec3 w0, vec3 w1, vec3 w2) {
    vec3 b0, b1, b2;
    env_sh_bands(N, b0, b1, b2);
    vec3 e = max(w0 * b0 + w1 * b1 + w2 * b2, vec3(0.0));
#if ENV_RAYS > 0
    return max(env_vis.rgb + env_vis.w * (e - env_sh_irradiance(normalize(Nv))), vec3(0.0));
#else
    return e;
#endif
}

// the cosine-weighted hemispherical mean of rho_dt (eq. 32 for a whole environment): 3-point
// Gauss-Legendre in mu^2 (physics.environment.RHO_MU / RHO_W)
float env_rho_dt_mean(sampler2D rho_tex, SpecParams sp) {
    return 0.2777778 * surface_rho_dt(rho_tex, 0.3357106, sp) + 0.4444444 * surface_rho_dt(rho_tex, 0.7071068, sp)
         + 0.2777778 * surface_rho_dt(rho_tex, 0.9419651, sp);
}

vec3 env_level(float level, vec2 uv) {
    float h = float(textureSize(env_prefiltered, 0).y) / float(ENV_LEVELS);
    float v = clamp(uv.y * h, 0.5, h - 0.5);  // stay inside the level (no bleeding into the next)
    return texture(env_prefiltered, vec2(uv.x, (level * h + v) / (h * float(ENV_LEVELS)))).rgb;
}

// the pre-filtered radiance arriving from direction R for Beckmann m (linear between levels)
vec3 env_prefiltered_at(vec3 R, float m) {
    // the environment turned by yaw: look up R_y(-yaw) R (physics rotate_yaw)
    vec3 d = vec3(u_env_yaw.x * R.x - u_env_yaw.y * R.z, R.y, u_env_yaw.y * R.x + u_env_yaw.x * R.z);
    vec2 uv = vec2((atan(d.x, -d.z) + 3.14159265) / 6.28318531, acos(clamp(d.y, -1.0, 1.0)) / 3.14159265);
    float f = 0.0;
    if (m >= u_env_level_m[ENV_LEVELS - 1]) f = float(ENV_LEVELS - 1);
    else for (int k = 0; k < ENV_LEVELS - 1; ++k)
        if (m >= u_env_level_m[k] && m < u_env_level_m[k + 1])
            f = float(k) + (m - u_env_level_m[k]) / (u_env_level_m[k + 1] - u_env_level_m[k]);
    float l0 = floor(f);
    float t = f - l0;
    vec3 a = env_level(l0, uv);
    return (t > 0.0) ? mix(a, env_level(min(l0 + 1.0, float(ENV_LEVELS - 1)), uv), t) : a;
}

// Lagarde & de Rousiers 2014 eq. 9: specular occlusion from the AO
float env_specular_occlusion(float nv, float ao, float m) {
    return clamp(pow(nv + ao, exp2(-16.0 * m - 1.0)) - 1.0 + ao, 0.0, 1.0);
}

// the environment's specular (split sum), shading normal N, view V, vertex normal Nv
vec3 env_specular(vec3 N, vec3 V, vec3 Nv, SpecParams sp) {
    float nv = clamp(dot(N, V), 0.0, 1.0);
    vec3 R = reflect(-V, N);
    float albedo = 1.0 - surface_rho_dt(env_rho_dt, nv, sp);
#if ENV_RAYS > 0
    float so = env_specular_occlusion(nv, env_vis.w, sp.m);
#else
    float so = 1.0;
#endif
    return u_env_scale * env_prefiltered_at(R, sp.m) * (albedo * so);
}

// Phong's environment specular (physics/environment.env_phong_specular): the pre-filtered radiance at R for
// the Blinn-Phong lobe's Beckmann m = sqrt(2 / (n + 2)) x the lobe's albedo at V = N,
// 8 pi int_{1/sqrt2}^1 c^(n+1) (2c^2 - 1) dc in closed form, x phong.specular x specular occlusion
float env_phong_albedo(float n) {
    return 25.13274123 * (2.0 * (1.0 - exp2(-(n + 4.0) * 0.5)) / (n + 4.0) - (1.0 - exp2(-(n + 2.0) * 0.5)) / (n + 2.0));
}
vec3 env_phong_specular(vec3 N, vec3 V, float shininess, float specular) {
    float nv = clamp(dot(N, V), 0.0, 1.0);
    float m = sqrt(2.0 / (shininess + 2.0));
#if ENV_RAYS > 0
    float so = env_specular_occlusion(nv, env_vis.w, m);
#else
    float so = 1.0;
#endif
    return u_env_scale * env_prefiltered_at(reflect(-V, N), m) * (specular * env_phong_albedo(shininess) * so);
}
#endif
#endif
