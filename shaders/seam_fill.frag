#version 330 core
#pragma vertex_stage "vs/fullscreen.vert"
// Seam-aware blur input (issue 10 item 1, issue 14): a copy of `source` whose gutter texels near a
// UV seam hold the value of the surface point they stand for on the adjacent island (the seam map,
// scene/texels.py), so the blur that reads it with plain bilinear taps continues across seams. One
// cheap pass instead of redirecting each tap's four bilinear texels by hand in the blur itself.
uniform sampler2D source;
uniform sampler2D seam_map;  // RG: texel coordinate across the UV seam, B: 1 where there is one
out vec4 f_color;
void main() {
    ivec2 p = ivec2(gl_FragCoord.xy);
    vec4 s = texelFetch(seam_map, p, 0);
    f_color = (s.b > 0.5) ? texture(source, (s.rg + 0.5) / vec2(textureSize(source, 0)))
                          : texelFetch(source, p, 0);
}
