// The body of d'Eon's separable blur direction (deon_blur.frag, deon_blur_cs.comp): one source
// for the fragment draw and its compute twin, so both compute the same taps, weights and checks.
// One direction of a separable 7-tap Gaussian blur in texture space (seed 000 eq. 25-26):
//   out(x) = sum_k w_k in(x + k * step(x) * sigma),  k = -3..3, step = shear_step (u, then skewed v)
// stretch in UV per mm (stretch texture, or one uniform scale when stretch correction is off),
// sigma = sqrt(v_i - v_(i-1)) in mm. Each texel is computed at the island texel the gutter map
// names, so the output's gutters come out dilated. The output has the gutter map's size, which may
// be half the source's (deon.half_res_above_texels: the first pass of a half-size blur reads its
// full-size input by UV; taps are in UV, so only the texel grid of the output changes). RGB irradiance and A thickness are blurred alike.
// With scene.seam_aware, `source` is the seam-filled copy (seam_fill.frag): taps that leave their
// island read the surface across the seam, past a mesh border no light, and never another island
// (ISLAND_ZONES below).
#ifndef SKINVIEWER_DEON_BLUR_GLSL
#define SKINVIEWER_DEON_BLUR_GLSL
#include "lib/deon.glsl"
#include "lib/island_zones.glsl"
uniform sampler2D source;
uniform sampler2D stretch_map;
uniform sampler2D gutter;
uniform vec2 u_dir;               // (1, 0) horizontal (u), (0, 1) vertical (v)
uniform float u_sigma_mm;
uniform int u_use_stretch;
uniform vec2 u_uniform_stretch;   // UV per mm
uniform float u_weights[7];
uniform int u_shear;              // deon.stretch_shear: the second pass follows the shear

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

// With scene.seam_aware (ISLAND_ZONES) a tap in another island's zone (lib/island_zones.glsl) is
// dropped and the kernel renormalised (the centre tap always counts), or, from a texel beside a mesh
// border, counted as no light; tested only where the farthest tap can reach a zone border.
#ifdef ISLAND_ZONES
uniform sampler2D seam_map;  // A: 1 where the nearest island edge is a mesh border (seam_map in Python)
uniform int u_absorb;        // 1: light (past a border there is none); 0: the stretch chain (a metric)
#ifdef NO_ZONE_CHECKS
// drawn on the tiles where no texel's farthest tap reaches another zone (passes/deon.zone_split, issue
// 27): the check below would be false on every texel there, and llvmpipe would still pay its taps'
// zone fetches under a mask; the same values, bit for bit
#define ISLAND_CHECK(reach) false
#else
#define ISLAND_CHECK(reach) ((reach) > own.a)
#endif
#define PAST_BORDER ((u_absorb != 0) ? texelFetch(seam_map, src, 0).a : 0.0)
#else
#define ISLAND_CHECK(reach) false
#define PAST_BORDER 0.0
#endif

// deon.open_border = reflect (issue 30 item 5): when `source` is a blur of E, a tap past the island's
// mesh border (s < 0 on the border's line through x's nearest border point) reads the odd reflection
// of the light about the border (lib/open_border.glsl) instead of no light: the light the previous
// steps carried past the border comes back, as in eq. 21's one-go blur of E over the surface.
#ifdef OPEN_BORDER
#include "lib/open_border.glsl"
uniform int u_reflect;  // 0 for the first step's first pass over E itself (nothing past the border)
// the tap's foot on the border line lies in x's own island zone (past a corner it may not: then the
// tap is judged by its zone as before)
bool own_border(vec2 p, float s, vec2 nrm, float zone) {
    return abs(uv_zone(gutter, p - s * nrm / vec2(textureSize(gutter, 0))) - zone) < 0.5;
}
#endif

// the blurred value of output texel `frag` (deon_blur.frag draws it, deon_blur_cs.comp stores it)
vec4 deon_blur_at(ivec2 frag) {
    ivec2 src = ivec2(texelFetch(gutter, frag, 0).rg + 0.5);
    vec4 own = texelFetch(gutter, src, 0);  // B: this island's zone, A: texels to another zone
    float zone = abs(own.b);
    // next to a mesh border a tap in another zone lies past the surface's end: no light, its weight
    // kept (RGB); the thickness (A) is renormalised over the taps kept
    float absorb = PAST_BORDER;
    float wl = 0.0;
    ivec2 out_size = textureSize(gutter, 0);  // this pass's texel grid
    vec2 uv = (vec2(src) + 0.5) / vec2(out_size);
    // the stretch map is the irradiance map's size: a half-size grid reads every other texel
    vec4 st = (u_use_stretch != 0) ? texelFetch(stretch_map, src * textureSize(stretch_map, 0) / out_size, 0)
                                   : vec4(u_uniform_stretch, 0.0, 1.0);
    vec2 step_uv = shear_step(st.rg, (u_shear != 0) ? st.b : 0.0, u_dir) * u_sigma_mm;
    step_uv = vec2(finite_f32(step_uv.x), finite_f32(step_uv.y));
    vec4 acc = vec4(0.0);
#ifdef OPEN_BORDER
    vec4 bf = texelFetch(border_map, src, 0);
    bool reflect_on = u_reflect != 0 && bf.a > 0.5;
    // E / 2 where this pass's line of taps crosses the border (one read per texel, not per tap; along
    // the border's normal it is every tap's foot), or at x's foot when the line runs along the border
    vec2 tap_tx = step_uv * vec2(textureSize(source, 0));  // texels per unit of tap offset
    float rate = dot(bf.gb, tap_tx);
    vec3 half_e = !reflect_on ? vec3(0.0) : (abs(rate) > 1e-6) ? border_half_e(uv - bf.r / rate * step_uv, 0.0, bf.gb)
                                                            : border_half_e(uv, bf.r, bf.gb);
#endif
#ifdef NARROW_TAPS
    // a sigma of at most ~2 texels (issue 10 item 5): taps at whole texels along the axis, so no
    // bilinear smoothing adds variance: under a texel the 3-tap kernel of exactly sigma^2
    // (w_+-1 = sigma^2 / 2), above it the Gaussian sampled at the texels (variance within 0.4 %)
    float s_t = length(step_uv * vec2(textureSize(source, 0)));  // sigma in texels
    ivec2 d = ivec2(u_dir);
    ivec2 hi = textureSize(source, 0) - 1;
    float wsum = 0.0;
    bool check = ISLAND_CHECK(float(NARROW_TAPS) + 0.5);
#ifdef OPEN_BORDER
    float rate_n = dot(bf.gb, vec2(d));  // whole-texel taps along d
    vec3 half_e_n = !reflect_on ? vec3(0.0)
                  : (abs(rate_n) > 1e-6) ? border_half_e(uv - bf.r / rate_n * vec2(d) / vec2(textureSize(source, 0)), 0.0, bf.gb)
                                         : border_half_e(uv, bf.r, bf.gb);
#endif
    for (int k = -NARROW_TAPS; k <= NARROW_TAPS; ++k) {
        float fk = float(k);
        float w = (s_t <= 1.0) ? ((k == 0) ? 1.0 - s_t * s_t : ((abs(k) == 1) ? 0.5 * s_t * s_t : 0.0))
                               : exp(-fk * fk / (2.0 * s_t * s_t));
        ivec2 t = clamp(src + k * d, ivec2(0), hi);
#ifdef OPEN_BORDER
        // whole texels: a tap whose cell along the pass the border line crosses stands for its share c on
        // the surface (the discrete step would otherwise sit at the texel's edge, not at the border)
        float s_k = bf.r + fk * dot(bf.gb, vec2(d));  // texels into the surface at this tap's centre
        vec2 p_k = (vec2(src + k * d) + 0.5) / vec2(textureSize(source, 0));
        if (reflect_on && k != 0 && s_k < 0.0 && own_border(p_k, s_k, bf.gb, zone)) {
            acc += w * past_border_light(source, p_k, s_k, bf.gb, half_e_n);
            wsum += w;
            wl += w;
            continue;
        }
        float half_k = 0.5 * abs(dot(bf.gb, vec2(d)));  // the tap's cell [k - 1/2, k + 1/2] spans s_k +- half_k
        if (bf.a > 0.5 && s_k >= 0.0 && s_k < half_k && in_zone(gutter, t, zone, false) > 0.5) {
            float c = 0.5 + 0.5 * s_k / half_k;
            float s_p = 0.5 * (s_k - half_k);  // the middle of its part past the border
            vec4 v = texelFetch(source, t, 0);
            vec4 past = (u_reflect != 0)
                ? past_border_light(source, p_k + (s_p - s_k) * bf.gb / vec2(textureSize(source, 0)), s_p, bf.gb, half_e_n)
                : vec4(0.0);
            acc += w * vec4(c * v.rgb + (1.0 - c) * past.rgb, v.a);
            wsum += w;
            wl += w;
            continue;
        }
#endif
        float in_ = (check && k != 0) ? in_zone(gutter, t, zone, false) : 1.0;
        acc += w * in_ * texelFetch(source, t, 0);
        wsum += w * in_;
        wl += w * max(in_, absorb);
    }
    acc /= vec4(vec3(max(wl, 1e-30)), max(wsum, 1e-30));
#else
    vec2 ts = vec2(out_size);  // the zones' texels (the gutter map's)
    bool check = ISLAND_CHECK(3.0 * length(step_uv * ts) + 1.5);  // farthest tap, bilinear footprint
    float wsum = 0.0;
    for (int k = 0; k < 7; ++k) {
        vec2 t = uv + step_uv * float(k - 3);
        float w = u_weights[k];
#ifdef OPEN_BORDER
        float s_k = bf.r + float(k - 3) * dot(bf.gb, step_uv * ts);  // texels into the surface at this tap
        if (reflect_on && k != 3 && s_k < 0.0 && own_border(t, s_k, bf.gb, zone)) {
            acc += w * past_border_light(source, t, s_k, bf.gb, half_e);
            wsum += w;
            wl += w;
            continue;
        }
#endif
        float in_ = (check && k != 3) ? in_zone(gutter, ivec2(floor(t * ts)), zone, true) : 1.0;
        acc += w * in_ * texture(source, t);
        wsum += w * in_;
        wl += w * max(in_, absorb);
    }
    acc /= vec4(vec3(max(wl, 1e-30)), max(wsum, 1e-30));
#endif
    return finite4_f32(acc);
}
#endif
