#version 330 core
#pragma vertex_stage "vs/fullscreen.vert"
// Jimenez et al. 2009 (seed 001 §3.2 step 4, eq. 3.1 profile): sum_i w_i blur_i per channel on
// skin; other pixels keep the unblurred diffuse.
#include "lib/screen_space.glsl"
uniform sampler2D diffuse;   // ss_diffuse (mask in a)
uniform sampler2D blur0;
uniform sampler2D blur1;
uniform sampler2D blur2;
uniform sampler2D blur3;
uniform sampler2D blur4;
uniform sampler2D blur5;
uniform sampler2D blur6;
uniform sampler2D blur7;
uniform int u_count;
uniform vec3 u_w[MAX_GAUSSIANS];
out vec4 f_color;
void main() {
    ivec2 p = ivec2(gl_FragCoord.xy);
    vec4 c = texelFetch(diffuse, p, 0);
    if (c.a < 0.5) { f_color = finite4_f32(c); return; }
    vec3 acc = vec3(0.0);
    if (u_count > 0) acc += u_w[0] * texelFetch(blur0, p, 0).rgb;
    if (u_count > 1) acc += u_w[1] * texelFetch(blur1, p, 0).rgb;
    if (u_count > 2) acc += u_w[2] * texelFetch(blur2, p, 0).rgb;
    if (u_count > 3) acc += u_w[3] * texelFetch(blur3, p, 0).rgb;
    if (u_count > 4) acc += u_w[4] * texelFetch(blur4, p, 0).rgb;
    if (u_count > 5) acc += u_w[5] * texelFetch(blur5, p, 0).rgb;
    if (u_count > 6) acc += u_w[6] * texelFetch(blur6, p, 0).rgb;
    if (u_count > 7) acc += u_w[7] * texelFetch(blur7, p, 0).rgb;
    f_color = finite4_f32(vec4(acc, c.a));
}
