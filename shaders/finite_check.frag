#version 330 core
#pragma vertex_stage "vs/fullscreen.vert"
// Non-finite texel detector (the graph's check after a pass ran): each fragment of a small grid
// scans one tile of the source and writes 1 when any component is NaN or Inf. The test is on the
// bits (exponent all ones), so no compiler "fast math" can fold it away.
uniform sampler2D src;
uniform ivec2 u_tile;  // texels per fragment
uniform ivec2 u_size;  // source size
out vec4 f_bad;
bool nonfinite(vec4 v) {
    uvec4 e = floatBitsToUint(v) & uvec4(0x7f800000u);
    return any(equal(e, uvec4(0x7f800000u)));
}
void main() {
    ivec2 o = ivec2(gl_FragCoord.xy) * u_tile;
    ivec2 hi = min(o + u_tile, u_size);
    float bad = 0.0;
    for (int y = o.y; y < hi.y; ++y)
        for (int x = o.x; x < hi.x; ++x)
            if (nonfinite(texelFetch(src, ivec2(x, y), 0))) bad = 1.0;
    f_bad = vec4(bad);
}
