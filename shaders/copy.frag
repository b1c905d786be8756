#version 330 core
#pragma vertex_stage "vs/fullscreen.vert"
// A plain full-screen copy (one texel fetch): the yardstick of benchmarks/bench_frames.py for the
// cost of a full-screen draw of a given size and format.
uniform sampler2D source;
out vec4 f_color;
void main() {
    f_color = texelFetch(source, ivec2(gl_FragCoord.xy), 0);
}
