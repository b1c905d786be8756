#version 330 core
#pragma vertex_stage "vs/fullscreen.vert"
// The outer level of the direct gather (deon_surface_gather.frag): per 2 x 2 block of texels the
// sum of E A (RGB light, A thickness), the mean point, the area and the spread of its surface texels,
// and their island zone
// (0: none, or texels of two zones: the gather skips the block). Past a border (w < 0) a texel adds
// its area and thickness, and only the light of its part still on the surface (PAST_BORDER_SHARE).
#include "lib/gather_surface.glsl"
uniform sampler2D source;   // the blur's input, seam-filled
uniform sampler2D surface;  // deon_gather_surface.frag: xyz mm, w area mm^2
uniform sampler2D gutter;   // B island zone
layout(location = 0) out vec4 f_light;     // sum E A
layout(location = 1) out vec4 f_position;  // xyz sum P A, w sum A
layout(location = 2) out vec4 f_zone;      // R zone, G the block's own variance per axis (mm^2)
layout(location = 3) out vec4 f_lit;       // the same of its light (weight E.r + E.g + E.b): xyz mean, w spread
void main() {
    ivec2 b = ivec2(gl_FragCoord.xy);
    ivec2 hi = textureSize(source, 0) - 1;
    vec4 light = vec4(0.0), pos = vec4(0.0);
    float zone = 0.0, second = 0.0, lit_second = 0.0;
    vec4 lit = vec4(0.0);
    bool mixed = false;
    vec3 origin = texelFetch(surface, min(2 * b, hi), 0).xyz;  // moments about a point of the block: no cancellation
    for (int k = 0; k < 4; ++k) {
        ivec2 t = min(2 * b + ivec2(k & 1, k >> 1), hi);
        vec4 s = texelFetch(surface, t, 0);
        float a = abs(s.w);
        float z = abs(texelFetch(gutter, t, 0).b);
        if (a > 0.0) {
            mixed = mixed || (zone > 0.0 && abs(z - zone) > 0.5);
            zone = z;
            vec4 e = texelFetch(source, t, 0);
            vec3 rgb = a * ((s.w > 0.0) ? e.rgb : PAST_BORDER_SHARE * e.rgb);
            light += vec4(rgb, a * e.a);
            vec3 d = s.xyz - origin;
            pos += vec4(a * d, a);
            second += a * dot(d, d);
            float l = rgb.r + rgb.g + rgb.b;
            lit += vec4(l * d, l);
            lit_second += l * dot(d, d);
        }
    }
    vec3 mean = pos.xyz / max(pos.w, 1e-30);
    // the block as one Gaussian of its own spread (moment-matched, as the ground truth's clusters):
    // per-axis variance of its area about its mean point, half the 2D second moment
    float spread = max(0.5 * (second / max(pos.w, 1e-30) - dot(mean, mean)), 0.0);
    f_light = light;
    f_position = vec4(origin + mean, pos.w);  // xyz the mean point, w sum A
    f_zone = vec4(mixed ? 0.0 : zone, spread, 0.0, 1.0);
    // the light's own mean point and spread: a lit texel beside dark ones (a beam, a shadow edge) stays
    // where it is instead of moving to the block's centre
    vec3 lit_mean = (lit.w > 0.0) ? lit.xyz / lit.w : mean;
    float lit_spread = (lit.w > 0.0) ? max(0.5 * (lit_second / lit.w - dot(lit_mean, lit_mean)), 0.0) : spread;
    f_lit = vec4(origin + lit_mean, lit_spread);
}
