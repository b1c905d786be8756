#version 330 core
// Gutter fill: each texel outside the UV islands copies the nearest island texel (gutter map RG),
// so blurs and bilinear lookups never pull black in from empty texture space.
#include "lib/color.glsl"
in vec2 v_uv;
uniform sampler2D source;
uniform sampler2D gutter;  // RG: texel coordinate (integer) to copy from; B: 1 inside an island
out vec4 f_color;
void main() {
    ivec2 src = ivec2(texelFetch(gutter, ivec2(gl_FragCoord.xy), 0).rg + 0.5);
    vec4 c = texelFetch(source, src, 0);
    f_color = vec4(finite3(c.rgb), finite1(c.a));
}
