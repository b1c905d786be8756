#version 330 core
#pragma vertex_stage "vs/fullscreen.vert"
// Burley normalized-diffusion blur in screen space (Golubev 2018 / HDRP, spec §5.3; two-level sampling,
// seed 001 Algorithm 1, spec §7.6). The estimator is in lib/burley.glsl; this file reads the framework's
// buffers and applies the pixel cutoff: a kernel under floor(pi (radius px)^2 / 4) < 1 sample leaves the
// irradiance as it is, bit for bit (spec §5.3 step 3, T4.5).
#include "lib/color.glsl"
uniform sampler2D irradiance;   // ss_diffuse: rgb diffuse irradiance (texturing applied), a > 0.5: SSS pixel
uniform sampler2D lin_depth;    // ss_depth: r = linear view depth, mm
uniform float u_proj_scale;     // pixels per mm at 1 mm depth: proj[1][1] * height / 2
uniform float u_filter_radius;  // mm, P^-1(0.997) d
layout(location = 0) out vec4 o_diffuse;
layout(location = 1) out vec4 o_stats;  // samples, extra levels, skipped, base contrast
#if BURLEY_REUSE
// for burley_reuse.frag: the near samples' sums (kept) and the far samples' sums (pooled with the neighbours')
layout(location = 2) out vec4 o_near_w;  // rgb sum w of the samples nearer than u_reuse_split px, a = 1: blurred
layout(location = 3) out vec4 o_far;     // rgb sum w E of the far samples
layout(location = 4) out vec4 o_far_w;   // rgb sum w of the far samples
#endif

bool burley_fetch(ivec2 q, out vec3 E, out float z) {
    E = vec3(0.0);
    z = 0.0;
    if (any(lessThan(q, ivec2(0))) || any(greaterThanEqual(q, textureSize(irradiance, 0))))
        return false;
    vec4 e = texelFetch(irradiance, q, 0);
    if ((isnan(e.a) || e.a <= 0.5))
        return false;
    E = e.rgb;
    z = texelFetch(lin_depth, q, 0).r;
    return true;
}

#include "lib/burley.glsl"

void main() {
    ivec2 p = ivec2(gl_FragCoord.xy);
    vec4 c = texelFetch(irradiance, p, 0);
    o_diffuse = c;
    o_stats = vec4(0.0, 0.0, 0.0, -1.0);
#if BURLEY_REUSE
    o_near_w = vec4(0.0);
    o_far = vec4(0.0);
    o_far_w = vec4(0.0);
#endif
    if ((isnan(c.a) || c.a <= 0.5))
        return;
    float zc = texelFetch(lin_depth, p, 0).r;
    float ppm = u_proj_scale / max(zc, 1e-6);
    float rad = u_filter_radius * ppm;
    float n_avail = floor(BURLEY_PI * rad * rad / 4.0);
    if ((isnan(n_avail) || n_avail < 1.0)) {
        o_stats = vec4(0.0, 0.0, 1.0, -1.0);
        return;
    }
    float count, level, cmax;
    BurleyState st;
    vec3 e = burley_sss(p, zc, ppm, n_avail, count, level, cmax, st);
#if BURLEY_REUSE
    o_diffuse = vec4(st.acc, c.a);  // sum w E of the near samples
    o_near_w = vec4(st.wsum, 1.0);
    o_far = vec4(st.acc_o, 0.0);
    o_far_w = vec4(st.wsum_o, 0.0);
#else
    o_diffuse = vec4(finite4(vec4(e, 0.0), FLOAT_MAX).rgb, c.a);  // f4 target: float range
#endif
    o_stats = vec4(count, level, 0.0, cmax);
}
