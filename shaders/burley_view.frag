#version 330 core
#pragma vertex_stage "vs/fullscreen.vert"
// Burley view modes: 1 = where extra samples were taken (magenta: one extra level, orange: two;
// blue: SSS pixels under the pixel cutoff) over the lit image; 2 = samples per pixel as a heat map.
#include "lib/color.glsl"
in vec2 v_uv;
uniform sampler2D lit;
uniform sampler2D stats;
uniform int u_mode;
uniform float u_max_samples;
out vec4 f_color;
void main() {
    ivec2 p = ivec2(gl_FragCoord.xy);
    vec4 c = texelFetch(lit, p, 0);
    vec4 s = texelFetch(stats, p, 0);
    if (u_mode == 1) {
        vec3 tint = s.g > 1.5 ? vec3(1.0, 0.45, 0.0) : s.g > 0.5 ? vec3(1.0, 0.0, 1.0)
                  : s.b > 0.5 ? vec3(0.0, 0.3, 1.0) : vec3(-1.0);
        float lum = dot(finite3(c.rgb), vec3(0.2126, 0.7152, 0.0722));
        vec3 grey = vec3(lum);
        f_color = vec4(tint.r >= 0.0 ? mix(grey, tint * max(lum, 0.15) * 2.0, 0.7) : grey, c.a);
    } else {
        float t = clamp(s.r / u_max_samples, 0.0, 1.0);
        vec3 heat = clamp(vec3(3.0 * t, 3.0 * t - 1.0, 3.0 * t - 2.0), 0.0, 1.0);
        f_color = vec4(heat, max(c.a, s.r > 0.0 ? 1.0 : 0.0));
    }
}
