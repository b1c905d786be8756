#version 330 core
#pragma vertex_stage "vs/fullscreen.vert"
// Temporal accumulation of the Burley estimate on a still view (temporal reuse, spec §7.9): every frame
// the blur turns its disks by a new seed, so successive frames are independent estimates of the same
// pixels; each pixel keeps their running mean, up to u_max_n frames. Any change (camera included)
// restarts it from that frame's estimate (u_reset): reprojecting the mean through the depth was measured
// worse than the single frame while the camera turns (notes/ss2.md), so a moving view shows the plain
// per-frame estimate and a still one refines.
#include "lib/color.glsl"
uniform sampler2D current;   // this frame's blurred diffuse (rgb), a: SSS mask as the irradiance's
uniform sampler2D history;   // rgb: the running mean, a: n (frames in it; 0 = none)
uniform float u_max_n;
uniform int u_reset;
layout(location = 0) out vec4 o_diffuse;   // the accumulated estimate (rgb), a as the current
layout(location = 1) out vec4 o_history;   // rgb mean, a n

void main() {
    ivec2 p = ivec2(gl_FragCoord.xy);
    vec4 cur = texelFetch(current, p, 0);
    o_diffuse = cur;
    o_history = vec4(cur.rgb, 0.0);
    if (!(cur.a > 0.5))
        return;  // not an SSS pixel: passed through, no history
    float n = 1.0;
    vec3 mean = cur.rgb;
    vec4 h = texelFetch(history, p, 0);
    if (u_reset == 0 && h.a >= 1.0) {
        n = min(h.a + 1.0, u_max_n);
        mean = h.rgb + (cur.rgb - h.rgb) / n;  // running mean (an EMA of 1/n once n = max)
    }
    mean = finite4(vec4(mean, 0.0), FLOAT_MAX).rgb;
    o_diffuse = vec4(mean, cur.a);
    o_history = vec4(mean, n);
}
