#version 330 core
#pragma vertex_stage "vs/display.vert"
// The viewer's display (ui/display.py): a texture on the screen. DISPLAY_MODE (a define, one
// program per mode): 0 show as-is (already display-encoded), 1 inspect (exposure + sRGB encode +
// channel), 2 A/B split at u_divider, 3 |A-B| heat map.
#ifndef DISPLAY_MODE
#define DISPLAY_MODE 0
#endif
uniform sampler2D u_tex;
uniform sampler2D u_tex_b;
uniform int u_channel;
uniform float u_exposure;
uniform float u_divider;
uniform float u_gain;
uniform int u_components;
in vec2 v_uv;
out vec4 frag;

vec3 srgb(vec3 c) {
    c = max(c, vec3(0.0));
    return mix(c * 12.92, 1.055 * pow(c, vec3(1.0 / 2.4)) - 0.055, step(vec3(0.0031308), c));
}
vec3 heat(float t) {  // black -> blue -> red -> yellow -> white
    t = clamp(t, 0.0, 1.0);
    return clamp(vec3(3.0 * t - 1.0, 3.0 * t - 2.0, 0.0), 0.0, 1.0) + vec3(0.0, 0.0, clamp(3.0 * t, 0.0, 1.0) * (1.0 - clamp(3.0 * t - 1.5, 0.0, 1.0)));
}
void main() {
    vec4 a = texture(u_tex, v_uv);
#if DISPLAY_MODE == 0
    frag = vec4(a.rgb, 1.0);
#elif DISPLAY_MODE == 1
    vec4 v = a;
    if (any(isnan(v)) || any(isinf(v))) { frag = vec4(1.0, 0.0, 1.0, 1.0); return; }
    vec3 c;
    if (u_channel == 0) c = (u_components == 1) ? vec3(v.r) : (u_components == 2 ? vec3(v.rg, 0.0) : v.rgb);
    else if (u_channel == 1) c = vec3(v.r);
    else if (u_channel == 2) c = vec3(v.g);
    else if (u_channel == 3) c = vec3(v.b);
    else c = vec3(v.a);
    frag = vec4(srgb(c * u_exposure), 1.0);
#elif DISPLAY_MODE == 2
    vec4 b = texture(u_tex_b, v_uv);
    vec3 c = v_uv.x < u_divider ? a.rgb : b.rgb;
    float px = abs(v_uv.x - u_divider) * float(textureSize(u_tex, 0).x);
    if (px < 1.0) c = vec3(1.0, 0.85, 0.2);
    frag = vec4(c, 1.0);
#else
    vec4 b = texture(u_tex_b, v_uv);
    float d = length(a.rgb - b.rgb);
    frag = vec4(heat(d * u_gain), 1.0);
#endif
}
