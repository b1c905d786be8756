#version 330 core
#pragma vertex_stage "vs/fullscreen.vert"
// GPU reduction of the Burley statistics texture (samples, extra levels, skipped):
// STAGE 1 sums each row into a 1 x H texture (exact in float below 2^24 per row);
// STAGE 2 sums the rows in uint and writes 4096-based (hi, lo) pairs into a 2 x 1 texture:
// texel 0 = (samples hi, lo, triggered hi, lo), texel 1 = (skipped hi, lo, blurred pixels hi, lo).
#ifndef STAGE
#define STAGE 1
#endif
#if STAGE == 1
uniform sampler2D stats;
out vec4 f_out;
void main() {
    int y = int(gl_FragCoord.y);
    int w = textureSize(stats, 0).x;
    vec4 s = vec4(0.0);
    for (int x = 0; x < w; ++x) {
        vec4 t = texelFetch(stats, ivec2(x, y), 0);
        s += vec4(t.r, t.g > 0.5 ? 1.0 : 0.0, t.b > 0.5 ? 1.0 : 0.0, t.r > 0.5 ? 1.0 : 0.0);
    }
    f_out = s;
}
#else
uniform sampler2D rows;
out vec4 f_out;
vec2 hilo(uint v) { return vec2(float(v >> 12u), float(v & 4095u)); }
void main() {
    int h = textureSize(rows, 0).y;
    uvec4 s = uvec4(0u);
    for (int y = 0; y < h; ++y)
        s += uvec4(texelFetch(rows, ivec2(0, y), 0) + 0.5);
    f_out = int(gl_FragCoord.x) == 0 ? vec4(hilo(s.x), hilo(s.y)) : vec4(hilo(s.z), hilo(s.w));
}
#endif
