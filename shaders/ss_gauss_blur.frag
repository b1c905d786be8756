#version 330 core
#pragma vertex_stage "vs/fullscreen.vert"
// Jimenez et al. 2009 (seed 001 §3.2, eq. 3.2): one 1-D pass of the separable blur of one
// (incremental) Gaussian of std u_sigma_mm, on SSS-masked pixels only. Tap spacing in pixels:
//   x_k sigma s,  s = (alpha / 11) focal / (d + beta |grad_dir d|)   (eq. 3.2, calibrated: alpha = 11,
//   beta = 0 is the true projection; d linear depth mm, grad mm per pixel from ss_depth)
// Taps on background or non-skin pixels take the centre colour (no bleeding, energy kept).
#include "lib/screen_space.glsl"
// TAPS: the tap count, a compile-time define (constant loop bounds); the passes always set it
#ifndef TAPS
#define TAPS 7
#endif
uniform sampler2D source;      // rgb diffuse, a = SSS mask
uniform sampler2D depth_tex;   // ss_depth
uniform vec2 u_dir;            // (1, 0) horizontal, (0, 1) vertical
uniform float u_sigma_mm;
uniform float u_alpha;
uniform float u_beta;
uniform float u_focal;         // H / (2 tan(fov_y / 2))
uniform float u_x[TAPS];   // tap offsets in sigmas
uniform float u_w[TAPS];   // normalised weights
out vec4 f_color;
void main() {
    ivec2 p = ivec2(gl_FragCoord.xy);
    vec4 c = texelFetch(source, p, 0);
    if (c.a < 0.5) { f_color = finite4_f32(c); return; }  // not skin: unchanged
    vec4 dz = texelFetch(depth_tex, p, 0);
    float grad = u_dir.x > 0.5 ? dz.g : dz.b;
    float s = (u_alpha / 11.0) * u_focal / max(dz.r + u_beta * grad, 1e-6);  // px per mm, eq. 3.2
    float target = u_sigma_mm * s;  // the increment's std on screen (px)
    // Bilinear fetches at a fractional offset f add f (1 - f) px^2 of variance per tap: shrink the
    // tap spacing so the discrete kernel's variance is exactly target^2 (2 fixed-point steps;
    // skinviewer.physics.separable.bilinear_compensated_step)
    float step_px = target;
    for (int it = 0; it < 2; ++it) {
        float vb = 0.0;
        for (int k = 0; k < TAPS; ++k) {
            float f = fract(abs(u_x[k] * step_px));
            vb += u_w[k] * f * (1.0 - f);
        }
        step_px = sqrt(max(target * target - vb, 0.0));
    }
    vec2 texel = 1.0 / vec2(textureSize(source, 0));
    vec2 uv = (vec2(p) + 0.5) * texel;
    vec3 acc = vec3(0.0);
    for (int k = 0; k < TAPS; ++k) {
        vec4 t = texture(source, uv + u_dir * (u_x[k] * step_px) * texel);
        acc += u_w[k] * (t.a < 0.999 ? c.rgb : t.rgb);
    }
    f_color = finite4_f32(vec4(acc, c.a));
}
