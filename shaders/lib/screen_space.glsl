// Shared by the screen-space blur passes (skinviewer/passes/screen_space): the resources the
// lighting pass writes and helpers to read them. #include'd (no #version).
#ifndef SKINVIEWER_SCREEN_SPACE_GLSL
#define SKINVIEWER_SCREEN_SPACE_GLSL
// ss_diffuse: rgb = diffuse irradiance (x albedo^f), a = SSS mask (1 skin, 0 background/non-skin)
// ss_depth:   r = linear view depth (mm), g = |d depth/dx|, b = |d depth/dy| (mm per pixel, per 2x2
//             quad), a = coverage (1 mesh, 0 background)
float ss_finite(float x) { return (isnan(x) || isinf(x)) ? 0.0 : clamp(x, -FLOAT_MAX, FLOAT_MAX); }
vec4 ss_finite4(vec4 c) { return vec4(ss_finite(c.x), ss_finite(c.y), ss_finite(c.z), ss_finite(c.w)); }
// albedo^e without pow(0, 0): e <= 0 -> 1, c <= 0 -> 0
vec3 ss_safe_pow(vec3 c, float e) {
    c = clamp(c, 0.0, FLOAT_MAX);
    if (!(e > 0.0)) return vec3(1.0);
    return vec3(c.x > 0.0 ? pow(c.x, e) : 0.0, c.y > 0.0 ? pow(c.y, e) : 0.0, c.z > 0.0 ? pow(c.z, e) : 0.0);
}
// A tap of a screen-space blur that must not gather from the background or non-skin pixels, nor
// across depth steps: the tap's colour is lerped to the centre's by t in [0, 1] (energy kept,
// [SEP] SSSSBlurPS "follow surface"). t = 1 where the tap's mask is 0.
vec3 ss_guard_tap(vec4 tap, vec3 centre, float t) {
    float k = clamp(max(t, 1.0 - tap.a), 0.0, 1.0);
    return mix(tap.rgb, centre, k);
}
#endif
