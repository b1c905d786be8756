// Kelemen/Szirmay-Kalos specular (seed 000 eq. 14-16; seed 002 listings 14-1..14-3) and the rho_dt
// energy-conservation lookup (seed 000 eq. 30-31). GLSL 330, #include'd (no #version).
// Twin of skinviewer/specular.py: same guards, same values (float32). Never NaN/Inf for finite input:
//   m clamped to KS_M_MIN; tan^2 = |N x H|^2 / (N.H)^2 (no acos/tan); N.H <= 0 -> 0; N.L <= 0 -> 0;
//   |L+V|^2 < KS_HH_EPS (L = -V) -> 0; a zero N, L or V -> 0; no pow() of negatives.
// Textures (see specular.py): R32F, LINEAR, CLAMP_TO_EDGE; row = m, column = N.H or cos(theta),
// texel centres at (i + 0.5)/size, sampled as texture(tex, vec2(cosine, m)).
#ifndef SKINVIEWER_KELEMEN_GLSL
#define SKINVIEWER_KELEMEN_GLSL

const float KS_M_MIN = 1e-3;   // m -> 0 is a delta: 1/m^2 <= 1e6
const float KS_HH_EPS = 1e-6;  // |L+V|^2 below this: H undefined

vec3 ks_safe_normalize(vec3 v) {
    vec3 a = abs(v);
    float big = max(a.x, max(a.y, a.z));
    if ((isnan(big) || big <= 1e-30)) return vec3(0.0);
    v /= big;  // pre-scale: no overflow/underflow in dot()
    return v * inversesqrt(dot(v, v));
}

// eq. 14 / listing 14-1 (Schlick), base clamped to [0, 1]: H.V <= 0 -> F = 1
float fresnel_schlick(float h_dot_v, float f0) {
    float b = clamp(1.0 - max(h_dot_v, 0.0), 0.0, 1.0);
    float b2 = b * b;
    float e = b2 * b2 * b;
    return e + clamp(f0, 0.0, 1.0) * (1.0 - e);
}

// eq. 15 from cos and sin^2 of the N-H angle: exp(-tan^2/m^2) / (m^2 cos^4)
float ks_beckmann_sc(float c, float s2, float m) {
    if ((isnan(c) || c <= 0.0)) return 0.0;
    float mm = max(m, KS_M_MIN);
    float m2 = mm * mm;
    float c2 = max(c * c, 1e-12);  // exp(-s2/(c2 m2)) underflows to 0 long before this bites
    return exp(-s2 / (c2 * m2)) / (m2 * c2 * c2);
}

// eq. 15 / listing 14-2 PHBeckmann(ndoth, m)
float beckmann_ph(float n_dot_h, float m) {
    float c = min(n_dot_h, 1.0);
    return ks_beckmann_sc(c, max(1.0 - c * c, 0.0), m);
}

// listing 14-2 encoding inverted (listing 14-3): PH = (2 tex)^10, by multiplications
float ks_decode_beckmann(float t) {
    float x = max(2.0 * t, 0.0);
    float x2 = x * x;
    float x4 = x2 * x2;
    return x4 * x4 * x2;
}

// listing 14-3 (eq. 16): N.L * rho_s * max(PH F / dot(h, h), 0), h = L + V unnormalised. The BRDF
// f_r is rho_s PH F / dot(h, h) (reciprocal); N.L is the light's cosine.
// ks_frame: the guards shared by both modes; false when the specular is 0.
bool ks_frame(inout vec3 N, vec3 L, inout vec3 V, out vec3 H, out float hh, out float ndotl) {
    N = ks_safe_normalize(N);
    L = ks_safe_normalize(L);
    V = ks_safe_normalize(V);
    ndotl = dot(N, L);
    H = vec3(0.0);
    hh = 0.0;
    if ((isnan(ndotl) || ndotl <= 0.0) || dot(V, V) < 0.5) return false;  // N.L <= 0, or V was a zero vector
    vec3 h = L + V;
    hh = dot(h, h);
    if ((isnan(hh) || hh < KS_HH_EPS)) return false;
    H = h * inversesqrt(hh);
    return true;
}

float ks_combine(float PH, vec3 H, vec3 V, float hh, float ndotl, float rho_s, float f0) {
    return ndotl * max(rho_s, 0.0) * max(PH * fresnel_schlick(dot(H, V), f0) / hh, 0.0);
}

// direct: PH from eq. (15)
float ks_specular(vec3 N, vec3 L, vec3 V, float m, float rho_s, float f0) {
    vec3 H;
    float hh, ndotl;
    if (!ks_frame(N, L, V, H, hh, ndotl)) return 0.0;
    vec3 x = cross(N, H);
    return ks_combine(ks_beckmann_sc(dot(N, H), dot(x, x), m), H, V, hh, ndotl, rho_s, f0);
}

// GL_LINEAR with CLAMP_TO_EDGE at texel centres (i + 0.5)/size, with float weights: the hardware's
// filter quantises its weights (8 bits on NVIDIA: 1.3 % off numpy's twin, specular.sample_bilinear)
float ks_table_bilinear(sampler2D t, vec2 xy) {
    ivec2 size = textureSize(t, 0);
    vec2 f = clamp(xy, -1.0, 2.0) * vec2(size) - 0.5;
    vec2 i0 = floor(f), w = f - i0;
    ivec2 lo = clamp(ivec2(i0), ivec2(0), size - 1), hi = clamp(ivec2(i0) + 1, ivec2(0), size - 1);
    float a = texelFetch(t, lo, 0).r, b = texelFetch(t, ivec2(hi.x, lo.y), 0).r;
    float c = texelFetch(t, ivec2(lo.x, hi.y), 0).r, d = texelFetch(t, hi, 0).r;
    return mix(mix(a, b, w.x), mix(c, d, w.x), w.y);
}

// listing 14-3: PH from the Beckmann texture of listing 14-2 (x = N.H, y = m)
float ks_specular_lut(vec3 N, vec3 L, vec3 V, float m, float rho_s, float f0, sampler2D beckmann_tex) {
    vec3 H;
    float hh, ndotl;
    if (!ks_frame(N, L, V, H, hh, ndotl)) return 0.0;
    float ndoth = dot(N, H);
    if ((isnan(ndoth) || ndoth <= 0.0)) return 0.0;
    float PH = ks_decode_beckmann(ks_table_bilinear(beckmann_tex, vec2(min(ndoth, 1.0), max(m, KS_M_MIN))));
    return ks_combine(PH, H, V, hh, ndotl, rho_s, f0);
}

// eq. 30-31 table lookup (specular.rho_dt_table): x = cos(theta), y = m; result in [0, 1]
float rho_dt_lookup(sampler2D rho_dt_tex, float cos_theta, float m) {
    float r = ks_table_bilinear(rho_dt_tex, vec2(clamp(cos_theta, 0.0, 1.0), clamp(m, 0.0, 1.0)));
    return clamp(r, 0.0, 1.0);
}

#endif
