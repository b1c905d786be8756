#version 330 core
#pragma vertex_stage "vs/fullscreen.vert"
// The summed step's texels from deon_gather_quad.frag's four half-size sums (issue 27): texel p takes
// the sum of the island texel the gutter map names (src = p on an island), which sits in block src / 2,
// target src & 1: the one-texel sum's output bit for bit, gutters dilated as it dilates them.
uniform sampler2D gutter;  // RG nearest island texel
uniform sampler2D q0;
uniform sampler2D q1;
uniform sampler2D q2;
uniform sampler2D q3;
out vec4 f_color;
void main() {
    ivec2 src = ivec2(texelFetch(gutter, ivec2(gl_FragCoord.xy), 0).rg + 0.5);
    ivec2 c = src >> 1;
    int t = (src.x & 1) + 2 * (src.y & 1);
    f_color = (t == 0) ? texelFetch(q0, c, 0) : (t == 1) ? texelFetch(q1, c, 0) : (t == 2) ? texelFetch(q2, c, 0) : texelFetch(q3, c, 0);
}
