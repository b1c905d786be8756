#version 330 core
#pragma vertex_stage "vs/fullscreen.vert"
// The surface the direct gather (deon_surface_gather.frag) sums over, once per mesh and size: per
// texel its point on the surface (xyz, mm) and the area it stands for (w, mm^2). Island texels: the
// texel centre and its area from the stretch map (eq. 27: |dP/du| |dP/dv| sin = sqrt(1 - c^2) /
// (s_u s_v), per texel^2). Under SEAM, gutter texels the seam map continues across a UV seam stand for
// the surface point there; those past a mesh border for the tangent plane's continuation (the island
// point mirrored through the nearest edge texel). Both are samples of this island's chart continued,
// with the area of its nearest texel; past a border w < 0: area that exists in the integral's
// normalisation but holds no light (the ground truth integrates over the surface that exists). w = 0:
// not surface.
#include "lib/color.glsl"
uniform sampler2D positions;    // uv_position raster, gutters dilated (mesh units)
uniform sampler2D gutter;       // RG nearest island texel
uniform sampler2D stretch_map;  // RG UV per mm, B shear cosine (deon_stretch.frag per triangle)
uniform float u_mm;             // mm per mesh unit
#ifdef SEAM
uniform sampler2D seam_map;     // RG texel across the seam, B 1 there, 2 past a border
#endif
out vec4 f_color;

ivec2 nearest_island(ivec2 t) { return ivec2(texelFetch(gutter, t, 0).rg + 0.5); }

float texel_area(ivec2 t) {
    vec3 s = texelFetch(stretch_map, t, 0).rgb;
    float n = float(textureSize(gutter, 0).x);
    float c = clamp(s.b, -0.95, 0.95);
    return finite_f32(sqrt(1.0 - c * c) / max(s.r * s.g * n * n, 1e-30));
}

vec3 position_mm(ivec2 t) { return texelFetch(positions, t, 0).xyz * u_mm; }

void main() {
    ivec2 p = ivec2(gl_FragCoord.xy);
    ivec2 src = nearest_island(p);
    vec4 out_ = vec4(0.0);
    if (src == p) {
        out_ = vec4(position_mm(p), texel_area(p));
    }
#ifdef SEAM
    else {
        vec4 s = texelFetch(seam_map, p, 0);
        ivec2 hi = textureSize(gutter, 0) - 1;
        ivec2 m = clamp(2 * src - p, ivec2(0), hi);
        vec3 mirrored = (nearest_island(m) == m) ? 2.0 * position_mm(src) - position_mm(m) : position_mm(src);
        if (s.b > 0.5 && s.b < 1.5) {  // across a seam: the surface point there
            vec3 P = texture(positions, (s.rg + 0.5) / vec2(textureSize(positions, 0))).xyz * u_mm;
            // snapped to the other island's edge texel (seam map A = 1): this side's surface continued.
            // A sample of this side's chart continued: this side's texel area, whatever the other's
            out_ = vec4((s.a > 0.5) ? mirrored : P, texel_area(src));
        } else if (s.b > 1.5) {  // past a mesh border: the tangent plane's continuation, no light
            out_ = vec4(mirrored, -texel_area(src));
        }
    }
#endif
    f_color = vec4(finite_f32(out_.x), finite_f32(out_.y), finite_f32(out_.z), finite_f32(out_.w));
}
