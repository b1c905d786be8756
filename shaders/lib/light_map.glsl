// Gosselin light map (seed 000 eq. 9-10) at one texel's surface point: sum over lights of
// fac_shadow * Lc * max(N.L, 0), with the mesh normal map; for light_map.frag (mesh unwrapped) and
// light_map_texels.frag (full-screen over the texel surface map). Written to an f4 texture: only
// NaN/Inf are removed and values are bounded by FLOAT_MAX (finite3's half-float clamp would clip a
// 1e5 light). Alpha = 1 inside the UV islands.
#ifndef SKINVIEWER_LIGHT_MAP_GLSL
#define SKINVIEWER_LIGHT_MAP_GLSL
#include "lib/color.glsl"
#include "lib/lights.glsl"
#include "lib/surface.glsl"
#include "lib/environment.glsl"
out vec4 f_color;

vec3 finite_f32(vec3 c) {
    bvec3 bad = bvec3(isnan(c.x) || isinf(c.x), isnan(c.y) || isinf(c.y), isnan(c.z) || isinf(c.z));
    return clamp(mix(c, vec3(0.0), bad), vec3(0.0), vec3(FLOAT_MAX));
}

// P, Nv, uv, T: the interpolated vertex position, normal, UV and tangent; dPdx, dPdy: the position's
// change per texel step (beam footprints)
void light_map(vec3 v_position, vec3 v_normal, vec2 v_uv, vec4 v_tangent, vec3 dPdx, vec3 dPdy) {
    set_light_footprint(dPdx, dPdy);  // beam lights: area coverage
    vec3 N = surface_normal(v_normal, v_tangent, v_uv);
    vec3 E = vec3(0.0);
    for (int i = 0; i < N_LIGHTS; ++i) {
        vec3 L;
        vec3 Lc = light_incident(i, v_position, L);
        float ndl = dot(N, L);
        if ((isnan(ndl) || ndl <= 0.0)) continue;  // also skips NaN normals
        E += Lc * (min(ndl, 1.0) * shadow_factor(i, v_position, normalize(v_normal)));
    }
#if ENV_LIGHT
    E += env_irradiance(N, v_normal);  // the environment, occluded (lib/environment.glsl)
#endif
    // a NaN (a bug, e.g. in an edited shader) is kept so that render.check_finite flags this pass
    bvec3 nan = bvec3(isnan(E.x), isnan(E.y), isnan(E.z));
    f_color = vec4(mix(clamp(E, vec3(0.0), vec3(FLOAT_MAX)), E, nan), 1.0);
}
#endif
