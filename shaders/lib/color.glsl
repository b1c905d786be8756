// sRGB transfer functions (IEC 61966-2-1); lighting is done in linear space.
#ifndef SKINVIEWER_COLOR_GLSL
#define SKINVIEWER_COLOR_GLSL
vec3 srgb_to_linear(vec3 c) {
    c = clamp(c, 0.0, 1.0);
    return mix(c / 12.92, pow((c + 0.055) / 1.055, vec3(2.4)), step(0.04045, c));
}
vec3 linear_to_srgb(vec3 c) {
    c = clamp(c, 0.0, 1.0);
    return mix(c * 12.92, 1.055 * pow(c, vec3(1.0 / 2.4)) - 0.055, step(0.0031308, c));
}
// Replace NaN/Inf by 0 and clamp to the half-float range: no pass ever writes a non-finite texel.
vec3 finite3(vec3 c) {
    bvec3 bad = bvec3(isnan(c.x) || isinf(c.x), isnan(c.y) || isinf(c.y), isnan(c.z) || isinf(c.z));
    return clamp(mix(c, vec3(0.0), bvec3(bad)), vec3(-HALF_MAX), vec3(HALF_MAX));
}
float finite1(float x) { return (isnan(x) || isinf(x)) ? 0.0 : clamp(x, -HALF_MAX, HALF_MAX); }
// NaN/Inf -> 0 and clamp to +-limit (the largest value the target texture format can hold).
vec4 finite4(vec4 c, float limit) {
    bvec4 bad = bvec4(isnan(c.x) || isinf(c.x), isnan(c.y) || isinf(c.y), isnan(c.z) || isinf(c.z),
                      isnan(c.w) || isinf(c.w));
    return clamp(mix(c, vec4(0.0), bad), vec4(-limit), vec4(limit));
}
// Float32 textures (irradiance, blurs, screen-space diffuse) must keep values beyond the half-float
// range (lights of 1e6): NaN/Inf -> 0 and clamp to +-FLOAT_MAX instead of HALF_MAX.
float finite_f32(float x) { return (isnan(x) || isinf(x)) ? 0.0 : clamp(x, -FLOAT_MAX, FLOAT_MAX); }
vec4 finite4_f32(vec4 c) { return vec4(finite_f32(c.x), finite_f32(c.y), finite_f32(c.z), finite_f32(c.w)); }
// For a pass that computes light from scratch (irradiance, light map): Inf -> +-FLOAT_MAX, but a NaN
// stays NaN so that render.check_finite names this pass (a NaN here is a bug, e.g. in an edited
// shader: replaced by 0 it only darkened the skin, unflagged); the blurs after it replace it by 0.
float bounded_f32(float x) { return isnan(x) ? x : clamp(x, -FLOAT_MAX, FLOAT_MAX); }
vec4 bounded4_f32(vec4 c) { return vec4(bounded_f32(c.x), bounded_f32(c.y), bounded_f32(c.z), bounded_f32(c.w)); }
// The same with the target format's limit (the gutter fill copies a pass's output: NaN kept, Inf bounded)
vec4 bounded4(vec4 c, float limit) {
    bvec4 nan = bvec4(isnan(c.x), isnan(c.y), isnan(c.z), isnan(c.w));
    return mix(clamp(c, vec4(-limit), vec4(limit)), c, nan);
}
// C^e for albedo C >= 0 without pow(0, 0) (undefined in GLSL): e <= 0 -> 1, C <= 0 -> 0 (seed 000 eq. 28, 34).
vec3 safe_pow(vec3 c, float e) {
    c = clamp(c, 0.0, FLOAT_MAX);
    if ((isnan(e) || e <= 0.0)) return vec3(1.0);
    return vec3(c.x > 0.0 ? pow(c.x, e) : 0.0, c.y > 0.0 ? pow(c.y, e) : 0.0, c.z > 0.0 ? pow(c.z, e) : 0.0);
}
#endif
