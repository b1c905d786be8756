#version 330 core
#pragma vertex_stage "vs/fullscreen.vert"
// The TSM's farthest first surface around each block of texels (issue 27): R = the largest light-space
// distance t.r of a lit point A that any TSM read of lib/tsm_transmit.glsl within the planned reach can
// return. Every eq. 33 term is exp(-m^2 / (k2 v)) with m = d(C) - t.r >= d(C) - R, so a texel C with
// (d(C) - R)^2 / (k2 v) past float32's underflow gets exactly 0 from every tap and gather sample
// (tsm_transmitted's TSM_SKIP). Two programs:
//  * TSM_MAX_BLOCK = 1: the largest t.r over u_block x u_block TSM texels (texels with no surface,
//    A < 0, are not read by the transmission: skipped; -FLOAT_MAX when the block has none);
//  * TSM_MAX_BLOCK = 0: that max dilated along u_axis by u_radii[c] blocks in channel c (run once per
//    axis: a box window; four windows, one per channel: the reaches of the Gaussians' reads, widest in
//    R), clamped to the map like the TSM's clamp-to-edge reads.
#include "lib/color.glsl"
uniform sampler2D src;
uniform int u_block;
uniform ivec2 u_axis;
uniform ivec4 u_radii;
out vec4 f_max;
void main() {
    ivec2 q = ivec2(gl_FragCoord.xy);
    ivec2 n = textureSize(src, 0);
    float hi = -FLOAT_MAX;
#if TSM_MAX_BLOCK
    for (int y = 0; y < u_block; ++y) for (int x = 0; x < u_block; ++x) {
        ivec2 t = q * u_block + ivec2(x, y);
        if (any(greaterThanEqual(t, n))) continue;
        vec4 s = texelFetch(src, t, 0);
        if (s.a >= 0.0) hi = max(hi, s.r);
    }
    f_max = vec4(hi);
#else
    vec4 h = vec4(-FLOAT_MAX);
    int w = max(max(u_radii.x, u_radii.y), max(u_radii.z, u_radii.w));
    for (int k = -w; k <= w; ++k) {
        ivec2 t = q + k * u_axis;
        if (any(lessThan(t, ivec2(0))) || any(greaterThanEqual(t, n))) continue;
        vec4 s = texelFetch(src, t, 0);
        bvec4 in_c = lessThanEqual(ivec4(abs(k)), u_radii);
        h = max(h, vec4(in_c.x ? s.x : -FLOAT_MAX, in_c.y ? s.y : -FLOAT_MAX, in_c.z ? s.z : -FLOAT_MAX,
                        in_c.w ? s.w : -FLOAT_MAX));
    }
    f_max = h;
#endif
}
