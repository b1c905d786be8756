#version 330 core
#pragma vertex_stage "vs/fullscreen.vert"
// One Gosselin Poisson blur iteration (seed 000 eq. 11-13):
//   size = 1 / (width, height)                                   (11)
//   radius = size * R, R from the radius map (texels, eq. 12)    (12)
//   pixel = (centre + sum_i source(coord + poisson(i) * radius)) / 13   (13)
// Taps are bilinear on a gutter-dilated source, CLAMP_TO_EDGE; with scene.seam_aware the source is
// the seam-filled copy (seam_fill.frag), so taps that leave their island continue across UV seams.
in vec2 v_uv;
uniform sampler2D source;
uniform sampler2D radius_map;  // R32F, per texel radius in texels (eq. 12 without size)
uniform vec2 u_poisson[12];    // skinviewer.poisson.POISSON_12
#ifdef RADIUS_MM
// gosselin.radius_mode "mm" (issue 10 item 6): radius per channel in mm (physics/poisson.radii_mm),
// UV per mm from the stretch map (seed 000 eq. 27): each channel taps at its own radius
uniform vec3 u_radius_mm;
uniform sampler2D stretch_map;
#endif
out vec4 f_color;

vec4 finite4(vec4 c) {
    bvec4 bad = bvec4(isnan(c.x) || isinf(c.x), isnan(c.y) || isinf(c.y),
                      isnan(c.z) || isinf(c.z), isnan(c.w) || isinf(c.w));
    return clamp(mix(c, vec4(0.0), bad), vec4(0.0), vec4(FLOAT_MAX));
}

void main() {
    ivec2 p = ivec2(gl_FragCoord.xy);
    vec2 size = 1.0 / vec2(textureSize(source, 0));          // (11)
    vec2 uv = (vec2(p) + 0.5) * size;
    vec4 sum = finite4(texelFetch(source, p, 0));
#ifdef RADIUS_MM
    vec2 s = clamp(texelFetch(stretch_map, p, 0).rg, vec2(0.0), vec2(10.0));  // UV per mm
    vec3 R = clamp(u_radius_mm, vec3(0.0), vec3(1e3));
    for (int i = 0; i < 12; ++i) {
        vec2 o = u_poisson[i] * s;
        vec4 r = finite4(texture(source, uv + o * R.r));
        sum += vec4(r.r, finite4(texture(source, uv + o * R.g)).g, finite4(texture(source, uv + o * R.b)).b, r.a);
    }
#else
    float R = texelFetch(radius_map, p, 0).r;
    R = (R >= 0.0 && R <= 1e6) ? R : 0.0;                       // also rejects NaN
    vec2 radius = size * R;                                     // (12)
    for (int i = 0; i < 12; ++i)
        sum += finite4(texture(source, uv + u_poisson[i] * radius));
#endif
    f_color = finite4(sum * (1.0 / 13.0));                      // (13)
}
