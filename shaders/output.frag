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
#ifndef BG_ENV
#define BG_ENV 0
#endif
#if BG_ENV
// render.background_environment (issue 32): the environment seen through this pixel (1: the image at
// 1024 x 512, 2: the pre-filtered level BG_LEVEL of lib/environment.glsl, blurred), exposed and
// tone-mapped like the skin, where the mesh does not cover the pixel
uniform sampler2D env_background;
uniform mat4 u_inv_view_proj;
uniform vec3 u_eye;
uniform vec2 u_env_yaw;   // cos, sin of the environment's yaw
uniform vec3 u_env_scale; // colour x intensity
vec3 background_radiance() {
    vec4 p = u_inv_view_proj * vec4(v_uv * 2.0 - 1.0, 1.0, 1.0);
    vec3 R = normalize(p.xyz / p.w - u_eye);
    vec3 d = vec3(u_env_yaw.x * R.x - u_env_yaw.y * R.z, R.y, u_env_yaw.y * R.x + u_env_yaw.x * R.z);
    vec2 uv = vec2((atan(d.x, -d.z) + 3.14159265) / 6.28318531, acos(clamp(d.y, -1.0, 1.0)) / 3.14159265);
#if BG_ENV == 2
    // one level of the stacked pre-filtered levels (7; physics SPEC_LEVELS_M), kept inside it
    float h = float(textureSize(env_background, 0).y) / 7.0;
    uv.y = (float(BG_LEVEL) * h + clamp(uv.y * h, 0.5, h - 0.5)) / (7.0 * h);
#endif
    return u_env_scale * textureLod(env_background, uv, 0.0).rgb;
}
#endif
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
#if BG_ENV
    vec3 bg = tone_map(finite3(background_radiance()) * u_exposure);
#else
    vec3 bg = u_background;
#endif
    f_color = vec4(linear_to_srgb(mix(bg, rgb, a)), 1.0);
}
