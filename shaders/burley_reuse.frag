#version 330 core
#pragma vertex_stage "vs/fullscreen.vert"
// Neighbourhood reuse of the far Burley samples (a variant beyond seed 001 ch. 4). Every pixel turned its
// disk by its own hash, so the far samples (>= u_reuse_split px from the centre) of the (2R+1)^2 pixels
// around p are independent estimates of nearly the same part of the kernel: a 1-px shift is small against
// their radius. Their sums are averaged with a tent weight over SSS neighbours on the same surface (depth
// step within what the local slope predicts plus u_reuse_dz mm); the near samples, where the peaked profile
// would be blurred by the shift, stay the pixel's own. Result = (near + mean far) / (near w + mean far w).
#include "lib/color.glsl"
uniform sampler2D partial;    // rgb: sum w E of the near samples; a: alpha of the irradiance
uniform sampler2D near_w;     // rgb: sum w of the near samples; a: 1 where the pixel was blurred
uniform sampler2D far;        // rgb: sum w E of the far samples
uniform sampler2D far_w;      // rgb: sum w of the far samples
uniform sampler2D lin_depth;  // ss_depth: r depth (mm), g, b |dz/dx|, |dz/dy| (mm per px)
uniform float u_reuse_dz;
out vec4 f_color;
const float TINY = 1.17549435e-38;
#ifndef REUSE_R
#define REUSE_R 1
#endif
void main() {
    ivec2 p = ivec2(gl_FragCoord.xy);
    vec4 own = texelFetch(partial, p, 0);
    vec4 nw = texelFetch(near_w, p, 0);
    if (nw.a < 0.5) {
        f_color = own;  // not blurred: the irradiance as it was (bit for bit)
        return;
    }
    vec4 dc = texelFetch(lin_depth, p, 0);
    ivec2 size = textureSize(partial, 0);
    vec3 acc = vec3(0.0);
    vec3 wt = vec3(0.0);
    float g_sum = 0.0;
    for (int dy = -REUSE_R; dy <= REUSE_R; ++dy) {
        for (int dx = -REUSE_R; dx <= REUSE_R; ++dx) {
            ivec2 q = p + ivec2(dx, dy);
            if (any(lessThan(q, ivec2(0))) || any(greaterThanEqual(q, size)))
                continue;
            float tol = u_reuse_dz + 1.5 * dot(dc.gb, abs(vec2(dx, dy)));
            if (texelFetch(near_w, q, 0).a < 0.5 || abs(texelFetch(lin_depth, q, 0).r - dc.r) > tol)
                continue;
            float g = float((REUSE_R + 1 - abs(dx)) * (REUSE_R + 1 - abs(dy)));
            acc += g * texelFetch(far, q, 0).rgb;
            wt += g * texelFetch(far_w, q, 0).rgb;
            g_sum += g;
        }
    }
    vec3 num = own.rgb + acc / g_sum;
    vec3 den = nw.rgb + wt / g_sum;
    f_color = vec4(finite4(vec4(num / max(den, vec3(TINY)), 0.0), FLOAT_MAX).rgb, own.a);
}
