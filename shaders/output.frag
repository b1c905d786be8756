#version 330 core
#pragma vertex_stage "vs/fullscreen.vert"
// Exposure, background composite and sRGB encoding of the linear lit image.
#include "lib/color.glsl"
in vec2 v_uv;
uniform sampler2D lit;
uniform float u_exposure;
uniform vec3 u_background;  // linear
out vec4 f_color;
void main() {
    vec4 c = texture(lit, v_uv);
    vec3 rgb = finite3(c.rgb) * u_exposure;
    float a = clamp(finite1(c.a), 0.0, 1.0);
    f_color = vec4(linear_to_srgb(mix(u_background, rgb, a)), 1.0);
}
