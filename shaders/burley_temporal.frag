#version 330 core
#pragma vertex_stage "vs/fullscreen.vert"
// Temporal accumulation of the Burley estimate on a still view (temporal reuse, spec §7.9): every frame
// the blur turns its disks by a new seed, so successive frames are independent estimates of the same
// pixels; each pixel keeps their running mean, up to u_max_n frames. Any change (camera included)
// restarts it from that frame's estimate (u_reset): reprojecting the mean through the depth was measured
// worse than the single frame while the camera turns (notes/ss2.md), so a moving view shows the plain
// per-frame estimate and a still one refines.
// TEMPORAL_REUSE 1 (the plan pools neighbours' far samples, burley_reuse.frag): two means are kept, of the
// pooled estimate (low noise, biased by the 1-px shift) and of the pixel's own samples (noisier, unbiased);
// what is shown moves from the first to the second as frames come in, so a restart shows the clean pooled
// frame and the converged image carries no pooling bias.
#include "lib/color.glsl"
uniform sampler2D current;   // this frame's blurred diffuse (rgb), a: SSS mask as the irradiance's
uniform sampler2D history;   // rgb: the running mean of `current`, a: n (frames in it; 0 = none)
uniform float u_max_n;
uniform int u_reset;
layout(location = 0) out vec4 o_diffuse;   // what is shown (rgb), a as the current
layout(location = 1) out vec4 o_history;   // rgb mean, a n
#ifndef TEMPORAL_REUSE
#define TEMPORAL_REUSE 0
#endif
#if TEMPORAL_REUSE
uniform sampler2D partial;      // the blur's own sums (burley_blur.frag with BURLEY_REUSE): near sum w E
uniform sampler2D near_w;       // near sum w
uniform sampler2D far;          // far sum w E
uniform sampler2D far_w;        // far sum w
uniform sampler2D history_own;  // rgb: the running mean of the own estimate
layout(location = 2) out vec4 o_history_own;
const float TINY = 1.17549435e-38;
#endif

void main() {
    ivec2 p = ivec2(gl_FragCoord.xy);
    vec4 cur = texelFetch(current, p, 0);
    o_diffuse = cur;
    o_history = vec4(cur.rgb, 0.0);
#if TEMPORAL_REUSE
    o_history_own = vec4(cur.rgb, 0.0);
#endif
    if ((isnan(cur.a) || cur.a <= 0.5))
        return;  // not an SSS pixel: passed through, no history
    float n = 1.0;
    vec3 mean = cur.rgb;
    vec4 h = texelFetch(history, p, 0);
    bool keep = u_reset == 0 && h.a >= 1.0;
    if (keep) {
        n = min(h.a + 1.0, u_max_n);
        mean = h.rgb + (cur.rgb - h.rgb) / n;  // running mean (an EMA of 1/n once n = max)
    }
    mean = finite4(vec4(mean, 0.0), FLOAT_MAX).rgb;
    vec3 shown = mean;
#if TEMPORAL_REUSE
    vec3 own = cur.rgb;  // a pixel the blur skipped (kernel under a pixel) has no own sums: as it is
    vec4 nw = texelFetch(near_w, p, 0);
    if (nw.a > 0.5) {
        vec3 num = texelFetch(partial, p, 0).rgb + texelFetch(far, p, 0).rgb;
        vec3 den = nw.rgb + texelFetch(far_w, p, 0).rgb;
        own = num / max(den, vec3(TINY));
    }
    vec3 own_mean = own;
    if (keep) {
        vec3 ho = texelFetch(history_own, p, 0).rgb;
        own_mean = ho + (own - ho) / n;
    }
    own_mean = finite4(vec4(own_mean, 0.0), FLOAT_MAX).rgb;
    o_history_own = vec4(own_mean, n);
    // from the pooled mean (frame 1) to the own mean (from half the frames on): the own mean's noise
    // falls as 1/n, the pooled one's bias stays
    float t = clamp((n - 1.0) / max(0.5 * u_max_n - 1.0, 1.0), 0.0, 1.0);
    shown = mix(mean, own_mean, t);
#endif
    o_diffuse = vec4(shown, cur.a);
    o_history = vec4(mean, n);
}
