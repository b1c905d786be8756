#version 330 core
#pragma vertex_stage "vs/fullscreen.vert"
// Exposure, tone map (TONE_MAP 0 linear clamp, 1 filmic: Narkowicz's ACES fit), background composite
// and sRGB encoding of the linear lit image. passes/output.py:tone_map is the same curve in numpy.
#include "lib/color.glsl"
#ifndef TONE_MAP
#define TONE_MAP 1
#endif
in vec2 v_uv;
uniform sampler2D lit;
uniform float u_exposure;
uniform vec3 u_background;  // linear
out vec4 f_color;
vec3 tone_map(vec3 x) {
    x = max(x, vec3(0.0));
#if TONE_MAP == 1
    return clamp(x * (2.51 * x + 0.03) / (x * (2.43 * x + 0.59) + 0.14), 0.0, 1.0);
#else
    return clamp(x, 0.0, 1.0);
#endif
}
void main() {
    vec4 c = texture(lit, v_uv);
    vec3 rgb = tone_map(finite3(c.rgb) * u_exposure);
    float a = clamp(finite1(c.a), 0.0, 1.0);
    f_color = vec4(linear_to_srgb(mix(u_background, rgb, a)), 1.0);
}
