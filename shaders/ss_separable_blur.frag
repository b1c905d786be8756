#version 330 core
#pragma vertex_stage "vs/fullscreen.vert"
// Jimenez et al. 2015 separable SSS (seed 001 §3.3; spec §4.2 SSSSBlurPS), one 1-D pass:
//   out = k_0 c_M + sum_(i>=1) k_i c(uv + x_i step dir),  step = (width / 3) focal / d_M pixels per
//   profile mm (x mask strength), follow surface: c_i <- lerp(c_i, c_M, saturate(|d_M - d_i| / thr)).
// Rotation (seed 001 §3.3.4): taps within u_rot_fraction of the kernel's extent turn by a
// per-pixel random angle (same angle in both passes); outer taps stay on the axis.
#include "lib/screen_space.glsl"
// TAPS: the tap count, a compile-time define (constant loop bounds); the passes always set it
#ifndef TAPS
#define TAPS 17
#endif
uniform sampler2D source;      // rgb diffuse, a = SSS mask (strength)
uniform sampler2D depth_tex;   // ss_depth
uniform vec2 u_dir;
uniform float u_width_mm;
uniform float u_focal;
uniform vec3 u_k[TAPS];    // kernel weights, centre first
uniform float u_x[TAPS];   // offsets, profile mm
uniform int u_follow;
uniform float u_follow_mm;
uniform int u_rotate;
uniform float u_rot_fraction;
out vec4 f_color;

float ss_hash(ivec2 p) {  // integer hash -> [0, 1) (no sin(): stable across drivers)
    uint h = uint(p.x) * 1664525u ^ (uint(p.y) * 22695477u + 1013904223u);
    h ^= h >> 16; h *= 0x7feb352du; h ^= h >> 15; h *= 0x846ca68bu; h ^= h >> 16;
    return float(h >> 8) / 16777216.0;
}

void main() {
    ivec2 p = ivec2(gl_FragCoord.xy);
    vec4 c = texelFetch(source, p, 0);
    if (c.a < 0.5) { f_color = finite4_f32(c); return; }
    float dM = texelFetch(depth_tex, p, 0).r;
    float step_px = (u_width_mm / 3.0) * u_focal / max(dM, 1e-6) * c.a;
    vec2 texel = 1.0 / vec2(textureSize(source, 0));
    vec2 uv = (vec2(p) + 0.5) * texel;
    float xmax = 0.0;
    for (int i = 1; i < TAPS; ++i) { xmax = max(xmax, abs(u_x[i])); }
    float a = 6.28318530718 * ss_hash(p);
    mat2 R = mat2(cos(a), sin(a), -sin(a), cos(a));
    vec2 rdir = R * u_dir;
    vec3 acc = u_k[0] * c.rgb;
    for (int i = 1; i < TAPS; ++i) {
        vec2 d = (u_rotate != 0 && abs(u_x[i]) <= u_rot_fraction * xmax + 1e-6) ? rdir : u_dir;
        vec2 off = d * (u_x[i] * step_px) * texel;
        vec4 t = texture(source, uv + off);
        float k = t.a < 0.999 ? 1.0 : 0.0;  // never gather from background or non-skin
        if (u_follow != 0) {
            float di = texture(depth_tex, uv + off).r;
            k = max(k, clamp(abs(dM - di) / u_follow_mm, 0.0, 1.0));
        }
        acc += u_k[i] * mix(t.rgb, c.rgb, k);
    }
    f_color = finite4_f32(vec4(acc, c.a));
}
