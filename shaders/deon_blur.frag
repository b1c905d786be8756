#version 330 core
#pragma vertex_stage "vs/fullscreen.vert"
// One direction of a separable 7-tap Gaussian blur in texture space (seed 000 eq. 25-26):
//   out(x) = sum_k w_k in(x + k * step(x) * sigma),  k = -3..3, step = shear_step (u, then skewed v)
// stretch in UV per mm (stretch texture, or one uniform scale when stretch correction is off),
// sigma = sqrt(v_i - v_(i-1)) in mm. Each texel is computed at the island texel the gutter map
// names, so the output's gutters come out dilated. RGB irradiance and A thickness are blurred alike.
// With scene.seam_aware, `source` is the seam-filled copy (seam_fill.frag): taps that leave their
// island read the surface across the seam.
#include "lib/deon.glsl"
in vec2 v_uv;
uniform sampler2D source;
uniform sampler2D stretch_map;
uniform sampler2D gutter;
uniform vec2 u_dir;               // (1, 0) horizontal (u), (0, 1) vertical (v)
uniform float u_sigma_mm;
uniform int u_use_stretch;
uniform vec2 u_uniform_stretch;   // UV per mm
uniform float u_weights[7];
uniform int u_shear;              // deon.stretch_shear: the second pass follows the shear
out vec4 f_color;

// Tap spacing (UV) per mm of sigma, shear included (issue 10 item 2). The blur must have the UV
// covariance S = sigma^2 G^-1, G = J^T J the metric of the UV -> surface Jacobian J = [dP/du dP/dv]
// (per-axis stretch s = 1 / |dP/du|, 1 / |dP/dv|, shear c = cos of their angle). Two passes give
// it exactly, S = a a^T + b b^T: the first along u with a = (s_u, 0) (the per-axis pass of eq. 25),
// the second along b = (-c s_u, s_v) / sqrt(1 - c^2), which is v's axis when there is no shear.
vec2 shear_step(vec2 s, float c, vec2 dir) {
    if (dir.x > 0.5) return vec2(s.x, 0.0);
    c = clamp(finite_f32(c), -0.95, 0.95);
    return vec2(-c * s.x, s.y) * inversesqrt(1.0 - c * c);
}

void main() {
    ivec2 src = ivec2(texelFetch(gutter, ivec2(gl_FragCoord.xy), 0).rg + 0.5);
    vec2 uv = (vec2(src) + 0.5) / vec2(textureSize(source, 0));
    vec4 st = (u_use_stretch != 0) ? texelFetch(stretch_map, src, 0) : vec4(u_uniform_stretch, 0.0, 1.0);
    vec2 step_uv = shear_step(st.rg, (u_shear != 0) ? st.b : 0.0, u_dir) * u_sigma_mm;
    step_uv = vec2(finite_f32(step_uv.x), finite_f32(step_uv.y));
    vec4 acc = vec4(0.0);
#ifdef NARROW_TAPS
    // a sigma of at most ~2 texels (issue 10 item 5): taps at whole texels along the axis, so no
    // bilinear smoothing adds variance: under a texel the 3-tap kernel of exactly sigma^2
    // (w_+-1 = sigma^2 / 2), above it the Gaussian sampled at the texels (variance within 0.4 %)
    float s_t = length(step_uv * vec2(textureSize(source, 0)));  // sigma in texels
    ivec2 d = ivec2(u_dir);
    ivec2 hi = textureSize(source, 0) - 1;
    float wsum = 0.0;
    for (int k = -NARROW_TAPS; k <= NARROW_TAPS; ++k) {
        float fk = float(k);
        float w = (s_t <= 1.0) ? ((k == 0) ? 1.0 - s_t * s_t : ((abs(k) == 1) ? 0.5 * s_t * s_t : 0.0))
                               : exp(-fk * fk / (2.0 * s_t * s_t));
        acc += w * texelFetch(source, clamp(src + k * d, ivec2(0), hi), 0);
        wsum += w;
    }
    acc /= max(wsum, 1e-30);
#else
    for (int k = 0; k < 7; ++k)
        acc += u_weights[k] * texture(source, uv + step_uv * float(k - 3));
#endif
    f_color = finite4_f32(acc);
}
