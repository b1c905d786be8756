#version 330 core
#pragma vertex_stage "vs/fullscreen.vert"
// One direction of a separable 7-tap Gaussian blur in texture space (seed 000 eq. 25-26):
//   out(x) = sum_k w_k in(x + k * stretch(x) * sigma * dir),  k = -3..3
// stretch in UV per mm (stretch texture, or one uniform scale when stretch correction is off),
// sigma = sqrt(v_i - v_(i-1)) in mm. Each texel is computed at the island texel the gutter map
// names, so the output's gutters come out dilated. RGB irradiance and A thickness are blurred alike.
#include "lib/deon.glsl"
in vec2 v_uv;
uniform sampler2D source;
uniform sampler2D stretch_map;
uniform sampler2D gutter;
uniform vec2 u_dir;               // (1, 0) horizontal (u), (0, 1) vertical (v)
uniform float u_sigma_mm;
uniform int u_use_stretch;
uniform vec2 u_uniform_stretch;   // UV per mm
uniform float u_weights[7];
out vec4 f_color;
void main() {
    vec2 at = texelFetch(gutter, ivec2(gl_FragCoord.xy), 0).rg;  // fractional across a UV seam
    ivec2 src = ivec2(at + 0.5);
    vec2 uv = (at + 0.5) / vec2(textureSize(source, 0));
    vec2 s = (u_use_stretch != 0) ? texelFetch(stretch_map, src, 0).rg : u_uniform_stretch;
    float step_uv = deon_finite(dot(s, u_dir) * u_sigma_mm);
    vec4 acc = vec4(0.0);
    for (int k = 0; k < 7; ++k)
        acc += u_weights[k] * texture(source, uv + u_dir * (step_uv * float(k - 3)));
    f_color = deon_finite4(acc);
}
