#version 330 core
#pragma vertex_stage "vs/fullscreen.vert"
// The outer level of the direct gather (deon_surface_gather.frag), per 2 x 2 block of texels. Each
// block is one Gaussian of its own spread (moment-matched, as the ground truth's clusters; per-axis
// variance = half the 2D second moment about the mean point).
// BLOCK_SURFACE (once per mesh and size, GatherSurfacePass): the mean point, area and spread of its
// surface texels and their island zone (0: none, or texels of two zones: the gather skips the block).
// Otherwise (each gathered blur step): the sum of E A (RGB light, A thickness) and its light's own
// mean point and spread (weight E.r + E.g + E.b), so a lit texel beside dark ones (a beam, a shadow
// edge) stays where it is instead of moving to the block's centre. Past a border (w < 0) a texel adds
// its area and thickness, and only the light of its part still on the surface (PAST_BORDER_SHARE).
// MEAN_THICKNESS (deon_gather_sum.frag, whose weights hold the block's area): A is the block's mean
// thickness (sum a A / sum a) instead of the sum; MEAN_LIGHT adds the mean light (sum a E / sum a, RGB)
// with it, for the rings the sum takes at the area's mean point (its LIT_RING).
#include "lib/gather_surface.glsl"
uniform sampler2D surface;  // deon_gather_surface.frag: xyz mm, w area mm^2
#ifdef BLOCK_SURFACE
uniform sampler2D gutter;   // B island zone
layout(location = 0) out vec4 f_position;  // xyz the mean point, w sum A
layout(location = 1) out vec4 f_zone;      // R zone, G spread (mm^2 per axis)
#else
uniform sampler2D source;   // the blur's input, seam-filled
layout(location = 0) out vec4 f_light;     // sum E A
layout(location = 1) out vec4 f_lit;       // xyz the light's mean point, w its spread
#ifdef MEAN_LIGHT
layout(location = 2) out vec4 f_mean;      // RGB the mean light, A the mean thickness
#endif
#endif

// mean point and per-axis spread of weights w at offsets d (sums: w d, w, w |d|^2) about origin
vec4 moments(vec4 sum, float second, vec3 origin) {
    vec3 mean = sum.xyz / max(sum.w, 1e-30);
    return vec4(origin + mean, max(0.5 * (second / max(sum.w, 1e-30) - dot(mean, mean)), 0.0));
}

void main() {
    ivec2 b = ivec2(gl_FragCoord.xy);
    ivec2 hi = textureSize(surface, 0) - 1;
    vec3 origin = texelFetch(surface, min(2 * b, hi), 0).xyz;  // moments about a point of the block: no cancellation
    vec4 sum = vec4(0.0);
    float second = 0.0;
#ifdef BLOCK_SURFACE
    float zone = 0.0;
    bool mixed = false;
#else
    vec4 light = vec4(0.0);
    float sum_a = 0.0;
#endif
    for (int k = 0; k < 4; ++k) {
        ivec2 t = min(2 * b + ivec2(k & 1, k >> 1), hi);
        vec4 s = texelFetch(surface, t, 0);
        float a = abs(s.w);
        vec3 d = s.xyz - origin;
#ifdef BLOCK_SURFACE
        float z = abs(texelFetch(gutter, t, 0).b);
        mixed = mixed || (a > 0.0 && zone > 0.0 && abs(z - zone) > 0.5);
        zone = (a > 0.0) ? z : zone;
        float w = a;
#else
        vec4 e = texelFetch(source, t, 0);
        vec3 rgb = a * ((s.w > 0.0) ? e.rgb : PAST_BORDER_SHARE * e.rgb);
        light += vec4(rgb, a * e.a);
        sum_a += a;
        float w = rgb.r + rgb.g + rgb.b;
#endif
        sum += vec4(w * d, w);
        second += w * dot(d, d);
    }
#ifdef BLOCK_SURFACE
    vec4 m = moments(sum, second, origin);
    f_position = vec4(m.xyz, sum.w);
    f_zone = vec4(mixed ? 0.0 : zone, m.w, 0.0, 1.0);
#else
#ifdef MEAN_THICKNESS
    light.a /= max(sum_a, 1e-30);
#endif
    f_light = light;
#ifdef MEAN_LIGHT
    f_mean = vec4(light.rgb / max(sum_a, 1e-30), light.a);
#endif
    f_lit = moments(sum, second, origin);  // no light: any point (its weight multiplies no light)
#endif
}
