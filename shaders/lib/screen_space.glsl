// Shared by the screen-space blur passes (skinviewer/passes/screen_space): the resources the
// lighting pass writes and helpers to read them. #include'd (no #version).
#ifndef SKINVIEWER_SCREEN_SPACE_GLSL
#define SKINVIEWER_SCREEN_SPACE_GLSL
#include "lib/color.glsl"
// ss_diffuse: rgb = diffuse irradiance (x albedo^f), a = SSS mask (1 skin, 0 background/non-skin)
// ss_depth:   r = linear view depth (mm), g = |d depth/dx|, b = |d depth/dy| (mm per pixel, per 2x2
//             quad), a = coverage (1 mesh, 0 background)
// A tap of a screen-space blur that must not gather from the background or non-skin pixels, nor
// across depth steps: the tap's colour is lerped to the centre's by t in [0, 1] (energy kept,
// [SEP] SSSSBlurPS "follow surface"). t = 1 where the tap's mask is 0.
vec3 ss_guard_tap(vec4 tap, vec3 centre, float t) {
    float k = clamp(max(t, 1.0 - tap.a), 0.0, 1.0);
    return mix(tap.rgb, centre, k);
}
#endif
