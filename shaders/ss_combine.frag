#version 330 core
#pragma vertex_stage "vs/fullscreen.vert"
// Screen-space combine (seed 001 §3.1, §3.6): lit = blurred diffuse x albedo^(1-f) + specular;
// alpha = coverage (the output pass composites the background where it is 0).
#include "lib/color.glsl"
in vec2 v_uv;
uniform sampler2D diffuse;   // the blurred diffuse (rgb)
uniform sampler2D specular;  // ss_specular
uniform sampler2D albedo;    // ss_albedo
out vec4 f_color;
void main() {
    ivec2 p = ivec2(gl_FragCoord.xy);
    vec4 s = texelFetch(specular, p, 0);
    vec3 c = texelFetch(diffuse, p, 0).rgb * texelFetch(albedo, p, 0).rgb + s.rgb;
    f_color = vec4(finite3(c), clamp(finite1(s.a), 0.0, 1.0));
}
