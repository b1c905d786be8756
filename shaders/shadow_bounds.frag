#version 330 core
#pragma vertex_stage "vs/fullscreen.vert"
// The shadow map's lower envelope per block (issue 27; lib/lights.glsl SHADOW_BOUNDS): for block b of
// SHADOW_BOUNDS_BLOCK^2 texels, a plane P'(u) = a' + G . (u - u_b) in the map's uv (u_b the block's
// centre, G its depth slope at the block's centre) and the span s, such that every depth ds of
// the window [B b - m, B b + B + m)^2 (m = u_margin = shadow.pcf + 2: every texel a PCF lookup whose
// centre texel is in the block reads, +1 of rounding) lies in [P'(u_q), P'(u_q) + s] (up to the
// consumer's rounding margin). A receiver plane z(u) = c.z + g . (u - c) then bounds every tap's eq. (7)
// difference z - ds from above by z - P' and from below by z - P' - s: a lookup whose every tap is
// lit (or shadowed) is decided without its fetches. A block whose window leaves the map (clamped reads)
// stores s = -1: never decided.
//   RGBA = (a', G.x, G.y, s)
#include "lib/color.glsl"
#ifndef SHADOW_BOUNDS_BLOCK
#define SHADOW_BOUNDS_BLOCK 8  // passes.common.SHADOW_BOUNDS_BLOCK
#endif
uniform sampler2D depth;  // the shadow map (z/w in [0,1], eq. 6)
uniform int u_margin;
out vec4 f_bounds;
void main() {
    const int B = SHADOW_BOUNDS_BLOCK;
    ivec2 b = ivec2(gl_FragCoord.xy);
    ivec2 n = textureSize(depth, 0);
    ivec2 lo = b * B - u_margin, hi = b * B + B + u_margin - 1;
    if (any(lessThan(lo, ivec2(0))) || any(greaterThanEqual(hi, n))) {
        f_bounds = vec4(0.0, 0.0, 0.0, -1.0);
        return;
    }
    vec2 size = vec2(n);
    ivec2 o = b * B;
    // the slope at the block's centre texel q: per axis the one-sided difference over 3 texels of the
    // smaller size (minmod), so a silhouette or the cleared background on one side does not tilt it
    ivec2 q = o + B / 2;
    float d0 = texelFetch(depth, q, 0).r;
    float xl = d0 - texelFetch(depth, q - ivec2(3, 0), 0).r, xr = texelFetch(depth, q + ivec2(3, 0), 0).r - d0;
    float yl = d0 - texelFetch(depth, q - ivec2(0, 3), 0).r, yr = texelFetch(depth, q + ivec2(0, 3), 0).r - d0;
    vec2 G = vec2(abs(xl) < abs(xr) ? xl : xr, abs(yl) < abs(yr) ? yl : yr) * size / 3.0;
    vec2 ub = (vec2(o) + 0.5 * float(B)) / size;
    float rlo = FLOAT_MAX, rhi = -FLOAT_MAX;
    for (int y = lo.y; y <= hi.y; ++y) for (int x = lo.x; x <= hi.x; ++x) {
        float r = texelFetch(depth, ivec2(x, y), 0).r - dot(G, (vec2(x, y) + 0.5) / size - ub);
        rlo = min(rlo, r);
        rhi = max(rhi, r);
    }
    bool ok = !(isnan(rlo) || isnan(rhi) || isinf(G.x) || isinf(G.y) || isnan(G.x) || isnan(G.y));
    f_bounds = ok ? vec4(rlo, G, rhi - rlo) : vec4(0.0, 0.0, 0.0, -1.0);
}
