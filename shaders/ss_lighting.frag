#version 330 core
// Screen-space lighting (seed 001 §3.1-3.2, §3.5-3.6; spec §2, §6), four targets:
//   0 ss_diffuse  rgb = sum_lights Lc (N.L) fac_shadow x albedo^f, a = SSS mask (with TR_TARGETS > 0:
//                 ss_diffuse_direct, and ss_transmittance.frag adds the transmittance into ss_diffuse)
//   1 ss_specular rgb = sum_lights KS(N, L, V) Lc fac_shadow (seed 000 eq. 35), a = coverage 1
//   2 ss_depth    r = linear view depth mm, gb = |ddx|, |ddy| of it, a = coverage 1
//   3 ss_albedo   rgb = albedo^(1-f) (the combine pass's post-scatter factor), a = 1
//   4.. ss_transmitted_k (TR_TARGETS of them, one per shadow-casting light k, then the environment's):
//                 rgb = mask albedo^f Lc back (n/9), a = the thickness in mm -- all the transmittance but its profile T(d),
//                 which ss_transmittance.frag applies (a profile edit does not re-run this pass)
// f: 0 post-scatter, 1 pre-scatter, mix pre-and-post (seed 001 §3.6).
#include "lib/color.glsl"
#include "lib/lights.glsl"
#include "lib/surface.glsl"
#include "lib/specular_params.glsl"
#include "lib/screen_space.glsl"
#include "lib/environment.glsl"
#include "lib/tr_thickness.glsl"
in vec3 v_position;
in vec3 v_normal;
in vec2 v_uv;
in vec4 v_tangent;
in float v_depth_mm;
uniform vec3 u_eye;
uniform float u_mix;                  // f
uniform float u_region_sss[N_REGIONS];  // 1 skin, 0 not
uniform int u_has_regions;
// Jimenez 2010 transmittance (seed 001 eq. 3.18, spec §6.2): the thickness and weights here
// (lib/tr_thickness.glsl), T(d) in ss_transmittance.frag
#ifndef TR_TARGETS
#define TR_TARGETS 0
#endif
uniform int u_tr;
uniform float u_tr_wrap;
layout(location = 0) out vec4 o_diffuse;
layout(location = 1) out vec4 o_specular;
layout(location = 2) out vec4 o_depth;
layout(location = 3) out vec4 o_albedo;
#if TR_TARGETS > 0
layout(location = 4) out vec4 o_tr0;
#endif
#if TR_TARGETS > 1
layout(location = 5) out vec4 o_tr1;
#endif
#if TR_TARGETS > 2
layout(location = 6) out vec4 o_tr2;
#endif
#if TR_TARGETS > 3
layout(location = 7) out vec4 o_tr3;
#endif

void main() {
    set_light_footprint(dFdx(v_position), dFdy(v_position));  // beam lights: area coverage (lib/beam.glsl)
    vec3 Ng = normalize(v_normal);
    vec3 N = surface_normal(v_normal, v_tangent, v_uv);
    vec3 V = normalize(u_eye - v_position);
    if (!gl_FrontFacing) { N = -N; Ng = -Ng; }  // the back of an open sheet (scene.back_faces: show)
    vec3 A = max(texture(albedo_map, v_uv).rgb, vec3(0.0));
    SpecParams sp = specular_params(v_uv);
    vec3 E = vec3(0.0), spec = vec3(0.0);
    vec4 tr[4] = vec4[4](vec4(0.0), vec4(0.0), vec4(0.0), vec4(0.0));  // per shadow-casting light: weight, thickness
    int k = 0;
    for (int i = 0; i < N_LIGHTS; ++i) {
        vec3 L;
        vec3 Lc = light_incident(i, v_position, L);
        float ndl = dot(N, L);
        if (ndl > 0.0) {
            float s = shadow_factor(i, v_position, Ng);
            E += Lc * (ndl * s);
            spec += Lc * (surface_ks(N, L, V, sp) * s);
        }
        if (u_tr != 0 && u_light_shadowed[i] != 0 && k < 4) {
            // eq. 3.15 with [SEP]'s wrap: back-side irradiance through the inverted vertex normal
            float back = clamp(u_tr_wrap + dot(L, -Ng), 0.0, 1.0);
            vec2 t = back > 0.0 ? transmitted(i, v_position, Ng) : vec2(0.0);
            tr[k] = vec4(Lc * back * t.x, t.y);
            k += 1;
        }
    }
#if ENV_LIGHT
    ENV_VIS_IN();
    E += env_irradiance(N, v_normal);             // before the screen blur, like the lights
    spec += env_specular(N, V, v_normal, sp);
#if ENV_RAYS > 0
    // translucency from the environment (issue 32): the back side's irradiance E_SH(-Ng), through the
    // transmittance profile (ss_transmittance.frag) at the baked thickness along -N, in mm (a
    // documented approximation: notes/envlight.md); the last transmitted slot, after the lights'
    if (u_tr != 0 && k < 4) {
        tr[k] = vec4(env_back_irradiance(Ng), ENV_THICK().x * u_mm_per_unit);
        k += 1;
    }
#endif
#endif
    float mask = 1.0;
    if (u_has_regions != 0) mask = u_region_sss[region_at(ivec2(v_uv * vec2(textureSize(region_map, 0))))];
    vec3 Af = safe_pow(A, u_mix);
    o_diffuse = finite4_f32(vec4(E * Af, mask));
    // non-skin pixels scatter nothing: the transmittance belongs to skin
#if TR_TARGETS > 0
    o_tr0 = finite4_f32(vec4(mask * Af * tr[0].rgb, tr[0].a));
#endif
#if TR_TARGETS > 1
    o_tr1 = finite4_f32(vec4(mask * Af * tr[1].rgb, tr[1].a));
#endif
#if TR_TARGETS > 2
    o_tr2 = finite4_f32(vec4(mask * Af * tr[2].rgb, tr[2].a));
#endif
#if TR_TARGETS > 3
    o_tr3 = finite4_f32(vec4(mask * Af * tr[3].rgb, tr[3].a));
#endif
    o_specular = finite4(vec4(spec, 1.0), HALF_MAX);  // a half-float target
    float d = v_depth_mm;
    o_depth = finite4_f32(vec4(d, abs(dFdx(d)), abs(dFdy(d)), 1.0));
    o_albedo = finite4(vec4(safe_pow(A, 1.0 - u_mix), 1.0), HALF_MAX);
}
