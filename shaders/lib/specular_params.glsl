// Per-texel Kelemen/Szirmay-Kalos parameters shared by every technique: m and rho_s per facial
// region (specular.per_region, region-ID map), rho_s scaled by the mesh's specular map, and the
// evaluation mode (direct eq. 15, or the Beckmann texture of seed 002 listing 14-2).
#ifndef SKINVIEWER_SPECULAR_PARAMS_GLSL
#define SKINVIEWER_SPECULAR_PARAMS_GLSL
#include "kelemen.glsl"
#include "surface.glsl"
uniform sampler2D region_map;      // R8, nearest: id = index in settings.REGIONS
uniform sampler2D specular_map;    // rho_s scale
uniform float u_spec_m[N_REGIONS];
uniform float u_spec_rho_s[N_REGIONS];
uniform float u_spec_rho_s_table;  // the rho_s the rho_dt table was computed for
uniform float u_f0;
uniform int u_spec_lut;
uniform sampler2D beckmann_tex;

struct SpecParams { float m; float rho_s; };

int region_at(ivec2 texel) {
    int id = int(texelFetch(region_map, texel, 0).r * 255.0 + 0.5);
    return (id < 0 || id >= N_REGIONS) ? 0 : id;
}

// The region parameters of the four nearest region-map texels, blended bilinearly: no hard line
// where two regions with different m or rho_s meet.
SpecParams specular_params(vec2 uv) {
    ivec2 size = textureSize(region_map, 0);
    vec2 st = uv * vec2(size) - 0.5;
    ivec2 i0 = ivec2(floor(st));
    vec2 f = clamp(st - vec2(i0), 0.0, 1.0);
    float m = 0.0, rho = 0.0;
    for (int k = 0; k < 4; ++k) {
        ivec2 o = ivec2(k & 1, k >> 1);
        int id = region_at(clamp(i0 + o, ivec2(0), size - 1));
        float w = (o.x == 1 ? f.x : 1.0 - f.x) * (o.y == 1 ? f.y : 1.0 - f.y);
        m += w * u_spec_m[id];
        rho += w * u_spec_rho_s[id];
    }
    float scale = surface_map(specular_map, uv).r;
    scale = (isnan(scale) || isinf(scale)) ? 1.0 : clamp(scale, 0.0, 10.0);
    return SpecParams(m, rho * scale);
}

// KS value for one light (includes N.L, listing 14-3)
float surface_ks(vec3 N, vec3 L, vec3 V, SpecParams sp) {
    return (u_spec_lut != 0) ? ks_specular_lut(N, L, V, sp.m, sp.rho_s, u_f0, beckmann_tex)
                             : ks_specular(N, L, V, sp.m, sp.rho_s, u_f0);
}

// rho_dt (eq. 30) at this texel: the table is linear in rho_s, 1 - rho_s I(cos, m), so another
// rho_s rescales its complement exactly.
float surface_rho_dt(sampler2D rho_dt_tex, float cos_theta, SpecParams sp) {
    float t = rho_dt_lookup(rho_dt_tex, cos_theta, sp.m);
    if ((isnan(u_spec_rho_s_table) || u_spec_rho_s_table <= 0.0)) return 1.0;
    return clamp(1.0 - (1.0 - t) * sp.rho_s / u_spec_rho_s_table, 0.0, 1.0);
}
#endif
