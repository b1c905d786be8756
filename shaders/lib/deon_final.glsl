// Final pass of d'Eon & Luebke 2007 (seed 000 eq. 34-35), view-dependent:
//   diffuse  = C^(1-mix) rho_dt(x, V) (sum_i w_i blur_i(uv) + transmitted)
//   transmitted = sum_i w_i (exp(-m^2 / 2 v_i) - exp(-r^2 / 2 v_i)) blur_i(uv_A)   (eq. 33 at the
//   true distance m, less what the surface blur carries: lib/tsm_transmit.glsl)
//   specular = sum_lights KS(N, L, V) Lc fac_shadow   (ks_* already carries N.L, eq. 35)
#ifndef SKINVIEWER_DEON_FINAL_GLSL
#define SKINVIEWER_DEON_FINAL_GLSL
#include "lib/color.glsl"
#include "lib/lights.glsl"
#include "lib/surface.glsl"
#include "lib/specular_params.glsl"
#include "lib/deon.glsl"
#include "lib/environment.glsl"
#ifndef FINAL_SCREEN
#define FINAL_SCREEN 0
#endif
#if FINAL_SCREEN  // the light part full-screen: the kept fragment's values, read from the view part's maps
vec3 g_position;
vec3 g_normal;
vec2 g_uv;
#define v_position g_position
#define v_normal g_normal
#define v_uv g_uv
#else
in vec3 v_position;
in vec3 v_normal;
in vec2 v_uv;
in vec4 v_tangent;
#endif
uniform vec3 u_eye;
uniform float u_mix;
uniform int u_energy;
uniform sampler2D rho_dt_tex;
uniform int u_tsm;
uniform int u_env_tr;            // deon.tsm: the environment's translucency too (ENV_RAYS > 0)
uniform vec3 u_env_tr_w[MAX_GAUSSIANS];   // deon.gaussians' weights and variances (mm^2), all of them
uniform float u_env_tr_v[MAX_GAUSSIANS];  // (u_w is zero where the sum comes from deon_combine)
uniform sampler2D diffuse_sum;   // sum_i w_i blur_i (+ transmitted) in texture space (deon_combine.frag)
uniform int u_combined;          // generic shaders: read diffuse_sum instead of the blurs
#ifndef DEON_TEXTURE_SHADOWS
#define DEON_TEXTURE_SHADOWS 0
#endif
#if DEON_TEXTURE_SHADOWS
uniform sampler2D visibility;    // fac_shadow per light slot, from the irradiance pass (deon_irradiance.frag)
#endif
// Split in two (issue 27; passes.deon.split_final), DEON_FINAL_PART: 0 the whole pass; 1 its
// light-independent part (DeonFinalViewPass: the shading normal N and m, the factor
// C^(1-mix) rho_dt(N.V) and rho_s, the environment's specular and translucency, and for the full-screen
// light part the fragment's position, uv and vertex normal, as exact float32 per pixel); 2 the light part
// (this pass), which reads them at its own pixel and adds the lights in the one-pass order: bit-identical.
// Over the mesh (deon_final.frag) the same raster and depth test land the same fragment there; full-screen
// (deon_final_light.frag, FINAL_SCREEN) the pixel's kept fragment is the stored one.
// Maps (passes.deon.final_view_roles; FINAL_LOC_*: the location of each optional one, -1 none):
//   over the mesh: N (N, m), F (C^(1-mix) rho_dt(N.V), rho_s), E (the environment's specular), X (its
//   translucency, C^mix applied); full-screen (FINAL_LOC_P >= 0): N (N, uv.x), F (the factor, uv.y),
//   P (position, m), E (the environment's specular, rho_s) or else S (rho_s), X, and NRM (the interpolated
//   vertex normal) where the light part reads it; a pixel no fragment reached keeps N = 0
#ifndef DEON_FINAL_PART
#define DEON_FINAL_PART 0
#endif
#ifndef FINAL_LOC_P
#define FINAL_LOC_P -1
#endif
#ifndef FINAL_LOC_S
#define FINAL_LOC_S -1
#endif
#ifndef FINAL_LOC_E
#define FINAL_LOC_E -1
#endif
#ifndef FINAL_LOC_X
#define FINAL_LOC_X -1
#endif
#ifndef FINAL_LOC_NRM
#define FINAL_LOC_NRM -1
#endif
#if DEON_FINAL_PART == 1
layout(location = 0) out vec4 f_view_n;
layout(location = 1) out vec4 f_view_f;
#if FINAL_LOC_P >= 0
layout(location = FINAL_LOC_P) out vec4 f_view_p;
#endif
#if FINAL_LOC_S >= 0
layout(location = FINAL_LOC_S) out vec4 f_view_s;
#endif
#if FINAL_LOC_E >= 0
layout(location = FINAL_LOC_E) out vec4 f_view_e;
#endif
#if FINAL_LOC_X >= 0
layout(location = FINAL_LOC_X) out vec4 f_view_x;
#endif
#if FINAL_LOC_NRM >= 0
layout(location = FINAL_LOC_NRM) out vec4 f_view_nrm;
#endif
#else
out vec4 f_color;
#endif
#if DEON_FINAL_PART == 2
uniform sampler2D final_view_n;
uniform sampler2D final_view_f;
#if FINAL_SCREEN
uniform sampler2D final_view_p;
#if FINAL_LOC_E < 0
uniform sampler2D final_view_s;  // rho_s without an environment
#endif
#if FINAL_LOC_NRM >= 0
uniform sampler2D final_view_nrm;
#endif
#endif
#if FINAL_LOC_E >= 0
uniform sampler2D final_view_e;
#endif
#if FINAL_LOC_X >= 0
uniform sampler2D final_view_x;
#endif
#endif

// Specialised (issue 14) by GAUSSIAN_MASK (bit i: Gaussian i has weight and its blur is bound),
// DEON_TSM (0: no transmission code) and DEON_COMBINED (1: the sum, transmission included, comes
// from deon_combine); GENERIC_SHADERS or no mask: every slot, uniform-driven.
#if defined(GAUSSIAN_MASK) && !defined(GENERIC_SHADERS)
#define G_MASK GAUSSIAN_MASK
#define G_TSM DEON_TSM
#define G_COMBINED DEON_COMBINED
#else
#define G_MASK 255
#define G_TSM 1
#define G_COMBINED (-1)  // uniform-driven (u_combined)
#endif
#include "lib/deon_blurs.glsl"
#include "lib/tsm_transmit.glsl"

void main() {
#if DEON_FINAL_PART != 1
#if G_MASK == 0 && G_TSM == 0 && defined(LIGHT_COUNT) && !defined(GENERIC_SHADERS)
#if LIGHT_COUNT == 0
    f_color = vec4(0.0, 0.0, 0.0, 1.0);  // every light off: black, as the full sum would give
    return;
#endif
#endif
#endif
#if DEON_FINAL_PART == 2
    ivec2 px = ivec2(gl_FragCoord.xy);  // the view part's values of this fragment
#if FINAL_SCREEN
    vec4 view0 = texelFetch(final_view_n, px, 0);
    if (view0.xyz == vec3(0.0)) {  // no fragment was kept here (a kept N is unit or NaN): a mesh draw's clear
        f_color = vec4(0.0);
        return;
    }
    vec4 view1 = texelFetch(final_view_f, px, 0);
    vec4 view_p = texelFetch(final_view_p, px, 0);
    g_position = view_p.xyz;
    g_uv = vec2(view0.w, view1.w);
#if FINAL_LOC_NRM >= 0
    g_normal = texelFetch(final_view_nrm, px, 0).xyz;
#endif
#if FINAL_LOC_E >= 0
    vec4 view_e = texelFetch(final_view_e, px, 0);
    SpecParams sp = SpecParams(view_p.w, view_e.w);
#else
    SpecParams sp = SpecParams(view_p.w, texelFetch(final_view_s, px, 0).r);
#endif
#else
    vec4 view0 = texelFetch(final_view_n, px, 0);
    vec4 view1 = texelFetch(final_view_f, px, 0);
#if FINAL_LOC_E >= 0
    vec4 view_e = texelFetch(final_view_e, px, 0);
#endif
    SpecParams sp = SpecParams(view0.w, view1.w);
#endif
#endif
#if DEON_FINAL_PART != 1 && !FINAL_SCREEN
    set_light_footprint(dFdx(v_position), dFdy(v_position));  // beam lights: area coverage
#endif
#if DEON_FINAL_PART == 2
    vec3 N = view0.xyz;  // gl_FrontFacing applied
#else
    vec3 N = surface_normal(v_normal, v_tangent, v_uv);
#endif
    vec3 V = normalize(u_eye - v_position);
#if DEON_FINAL_PART != 2
    if (!gl_FrontFacing) N = -N;  // the back of an open sheet (scene.back_faces: show)
#endif
    vec3 diffuse = vec3(0.0);
#if DEON_FINAL_PART != 1
#if G_COMBINED == 1
    diffuse = texture(diffuse_sum, v_uv).rgb;  // eq. (34), sum_i w_i blur_i, summed in texture space
#else
#if G_COMBINED == -1
    if (u_combined != 0) diffuse = texture(diffuse_sum, v_uv).rgb; else {
#endif
    vec4 here[MAX_GAUSSIANS];
    FETCH_BLURS(here, v_uv, HERE_MASK)
    for (int i = 0; i < MAX_GAUSSIANS; ++i) {
        if (i >= u_count) break;
        if (((G_MASK >> i) & 1) != 0 && u_used[i] != 0) diffuse += u_w[i] * here[i].rgb;  // eq. (34), sum_i w_i blur_i
    }
#if G_COMBINED == -1
    }
#endif
#endif
#if G_TSM != 0
    if (u_tsm != 0) diffuse += tsm_transmitted(v_position, v_normal, v_uv);  // eq. 33 (lib/tsm_transmit.glsl)
#endif
#endif
#if DEON_FINAL_PART != 2
    vec3 C = max(texture(albedo_map, v_uv).rgb, vec3(0.0));
#endif
#if ENV_LIGHT && ENV_RAYS > 0 && DEON_FINAL_PART != 2
    // translucency from the environment (issue 32; physics/environment.env_transmitted): the back side's
    // irradiance E_SH(-Ng) through eq. 33's profile sum_i w_i exp(-d^2 / 2 v_i) at the thickness d baked
    // along -N, times the pre-scatter albedo as the irradiance map's light is (deon.tsm gates it)
#if DEON_FINAL_PART == 1
    if (FINAL_LOC_X >= 0) {
#else
    if (u_env_tr != 0) {
#endif
        float d = ENV_THICK().x * u_mm_per_unit;
        vec3 t = vec3(0.0);
        for (int i = 0; i < MAX_GAUSSIANS; ++i) {
            if (u_env_tr_v[i] > 0.0) t += u_env_tr_w[i] * exp(-d * d / (2.0 * u_env_tr_v[i]));
        }
        vec3 env_tr = env_back_irradiance(normalize(v_normal)) * t * safe_pow(C, u_mix);
#if DEON_FINAL_PART == 1
#if FINAL_LOC_X >= 0
        f_view_x = vec4(env_tr, 0.0);
#endif
#else
        diffuse += env_tr;
#endif
    }
#endif
#if DEON_FINAL_PART == 2
#if FINAL_LOC_X >= 0
    diffuse += texelFetch(final_view_x, px, 0).rgb;
#endif
    diffuse *= view1.rgb;
#else
    SpecParams sp = specular_params(v_uv);
    float rho_v = (u_energy != 0) ? surface_rho_dt(rho_dt_tex, dot(N, V), sp) : 1.0;  // eq. (34)
    vec3 factor = safe_pow(C, 1.0 - u_mix) * rho_v;
    diffuse *= factor;
#endif
#if DEON_FINAL_PART == 1
#if FINAL_LOC_P >= 0  // packed for the full-screen light part: uv in N's and the factor's w
    f_view_n = vec4(N, v_uv.x);
    f_view_f = vec4(factor, v_uv.y);
    f_view_p = vec4(v_position, sp.m);
    float spare = sp.rho_s;  // in the environment specular's w, or a map of its own
#else
    f_view_n = vec4(N, sp.m);
    f_view_f = vec4(factor, sp.rho_s);
    float spare = 0.0;
#endif
#if FINAL_LOC_S >= 0
    f_view_s = vec4(spare);
#endif
#if FINAL_LOC_NRM >= 0
    f_view_nrm = vec4(v_normal, 0.0);
#endif
#if ENV_LIGHT && FINAL_LOC_E >= 0
    ENV_VIS_IN();
    f_view_e = vec4(env_specular(N, V, v_normal, sp), spare);  // split sum, specular occlusion (lib/environment.glsl)
#endif
#else
    vec3 spec = vec3(0.0);
#if DEON_TEXTURE_SHADOWS
    vec4 vis = texture(visibility, v_uv);  // eq. 10 per texel: no shadow-map lookups on a camera move
#endif
    for (int i = 0; i < N_LIGHTS; ++i) {
        vec3 L;
        vec3 Lc = light_incident(i, v_position, L);
        if ((isnan(dot(N, L)) || dot(N, L) <= 0.0)) continue;
        float ks = surface_ks(N, L, V, sp);
#if DEON_TEXTURE_SHADOWS
        spec += Lc * (ks * vis[i]);
#else
        spec += Lc * (ks * shadow_factor(i, v_position, normalize(v_normal)));
#endif
    }
#if ENV_LIGHT
    ENV_VIS_IN();
    spec += env_specular(N, V, v_normal, sp);  // split sum, specular occlusion (lib/environment.glsl)
#elif FINAL_LOC_E >= 0
    spec += view_e.rgb;  // the view part's env_specular
#endif
    f_color = vec4(finite3(diffuse + spec), 1.0);
#endif
}
#endif
