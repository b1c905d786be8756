#version 330 core
#pragma vertex_stage "vs/camera.vert"
// Gosselin final combination (seed 000 eq. 17-19):
//   diffuse  = C * blurred                                                          (17)
//   specular = sum_i KS_i * Lc_i * att                                              (18)
//   colour   = specular + diffuse                                                   (19)
// KS_i is listing 14-3 (includes N.L_i). att, the shadow attenuation of eq. (18), comes from the
// blurred light map. u_spec_shadow == 0 ("visibility", default):
//   att = clamp(LUM.blurred / LUM.E0, 0, 1),  E0 = sum_i Lc_i max(N.L_i, 0) (unshadowed irradiance)
//   + the environment's occluded irradiance (what the light map holds of it)
// a soft, dimensionless visibility in [0, 1] (specular never exceeds the unshadowed KS).
// u_spec_shadow == 1 ("printed"): eq. (18) as printed, BRDF (KS / N.L) * Lc * (LUM.blurred), where
// LUM.blurred stands for N.L * shadow; it scales with Lc^2 (dimensionally an irradiance too many).
#include "lib/color.glsl"
#include "lib/lights.glsl"
#include "lib/surface.glsl"
#include "lib/specular_params.glsl"
#include "lib/environment.glsl"
in vec3 v_position;
in vec3 v_normal;
in vec2 v_uv;
in vec4 v_tangent;
uniform vec3 u_eye;
uniform sampler2D blurred;        // f4 RGBA, blurred light map
uniform int u_spec_shadow;
out vec4 f_color;

const vec3 LUM = vec3(0.2125, 0.7154, 0.0721);

void main() {
    set_light_footprint(dFdx(v_position), dFdy(v_position));  // beam lights: area coverage
    vec3 N = surface_normal(v_normal, v_tangent, v_uv);
    vec3 V = ks_safe_normalize(u_eye - v_position);
    if (!gl_FrontFacing) N = -N;  // the back of an open sheet (scene.back_faces: show)
    vec3 C = max(finite3(texture(albedo_map, v_uv).rgb), vec3(0.0));
    vec3 E = max(finite3(texture(blurred, v_uv).rgb), vec3(0.0));
    vec3 color = C * E;                                                 // (17)

    SpecParams sp = specular_params(v_uv);

    float lumE = dot(LUM, E);
    vec3 E0 = vec3(0.0);
    vec3 spec = vec3(0.0);
    for (int i = 0; i < N_LIGHTS; ++i) {
        vec3 L;
        vec3 Lc = light_incident(i, v_position, L);
        float ndl = dot(N, L);
        if ((isnan(ndl) || ndl <= 0.0)) continue;
        E0 += Lc * min(ndl, 1.0);
        float ks = surface_ks(N, L, V, sp);
        if (u_spec_shadow == 1) ks /= max(ndl, 1e-6);  // the bare BRDF of eq. (16)
        spec += ks * Lc;
    }
#if ENV_LIGHT
    ENV_VIS_IN();
    // the environment's irradiance as it enters the light map: occluded by the baked transfer (issue 32),
    // so att is the analytic lights' visibility alone and a crease's env shadow does not dim their specular
    E0 += env_irradiance(N, v_normal);
#endif
    float att;
    if (u_spec_shadow == 1) {
        att = lumE;
    } else {
        float lumE0 = dot(LUM, E0);
        att = lumE0 > 1e-20 ? clamp(lumE / lumE0, 0.0, 1.0) : 0.0;
    }
    color += finite3(spec) * att;                                       // (18), (19)
#if ENV_LIGHT
    color += env_specular(N, V, v_normal, sp);  // split sum, specular occlusion (lib/environment.glsl)
#endif
    f_color = vec4(finite3(color), 1.0);
}
