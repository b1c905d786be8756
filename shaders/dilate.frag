#version 330 core
#pragma vertex_stage "vs/fullscreen.vert"
// Gutter fill: each texel outside the UV islands copies the nearest island texel (gutter map RG),
// so blurs and bilinear lookups never pull black in from empty texture space. Inf is bounded to the
// format's range; a NaN is copied as it is, so that the pass that made it is flagged, not hidden.
#include "lib/color.glsl"
in vec2 v_uv;
uniform sampler2D source;
uniform sampler2D gutter;  // RG: texel coordinate (integer) to copy from; B: 1 inside an island
uniform float u_limit;     // largest finite value of the target format (HALF_MAX or FLOAT_MAX)
layout(location = 0) out vec4 f_color;
// DILATE_MORE = 1 (issue 27): a second texture dilated in the same draw (d'Eon's irradiance and its
// visibility): one gutter fetch and one draw for both, each texel the same copy as alone
#ifndef DILATE_MORE
#define DILATE_MORE 0
#endif
#if DILATE_MORE
uniform sampler2D source1;
uniform float u_limit1;
layout(location = 1) out vec4 f_color1;
#endif
void main() {
    ivec2 src = ivec2(texelFetch(gutter, ivec2(gl_FragCoord.xy), 0).rg + 0.5);
    // NaN kept (render.check_finite then names the shading pass; the blurs after it replace it by 0)
    f_color = bounded4(texelFetch(source, src, 0), u_limit);
#if DILATE_MORE
    f_color1 = bounded4(texelFetch(source1, src, 0), u_limit1);
#endif
}
