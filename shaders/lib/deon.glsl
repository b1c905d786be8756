// Helpers of the d'Eon & Luebke 2007 passes (seed 000 §4.2).
#ifndef SKINVIEWER_DEON_GLSL
#define SKINVIEWER_DEON_GLSL
// Float32 textures (irradiance, blurs) must keep values beyond the half-float range (lights of
// 1e6): replace NaN/Inf by 0 and clamp to +-FLOAT_MAX instead of color.glsl's HALF_MAX.
float deon_finite(float x) { return (isnan(x) || isinf(x)) ? 0.0 : clamp(x, -FLOAT_MAX, FLOAT_MAX); }
vec4 deon_finite4(vec4 c) { return vec4(deon_finite(c.x), deon_finite(c.y), deon_finite(c.z), deon_finite(c.w)); }
// C^e for albedo C >= 0 without pow(0, 0) (undefined in GLSL): e <= 0 -> 1, C <= 0 -> 0.
vec3 deon_safe_pow(vec3 c, float e) {
    c = clamp(c, 0.0, FLOAT_MAX);
    if (!(e > 0.0)) return vec3(1.0);
    return vec3(c.x > 0.0 ? pow(c.x, e) : 0.0, c.y > 0.0 ? pow(c.y, e) : 0.0, c.z > 0.0 ? pow(c.z, e) : 0.0);
}
// Light-space distance in mm of the modified TSM (§4.2.7): along the light direction for a
// directional light, from the light position for a point light.
uniform int u_tsm_kind;   // LIGHT_DIRECTIONAL or LIGHT_POINT
uniform vec3 u_tsm_dir;   // towards the light
uniform vec3 u_tsm_pos;
uniform float u_mm_per_unit;
float tsm_distance_mm(vec3 P) {
    float d = (u_tsm_kind == LIGHT_POINT) ? length(P - u_tsm_pos) : -dot(P, u_tsm_dir);
    return d * u_mm_per_unit;
}
#endif
