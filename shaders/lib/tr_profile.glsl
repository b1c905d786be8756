// Jimenez 2010 transmittance (seed 001 eq. 3.18, spec §5.4/§6.2), its second half: the profile T(d)
// at a thickness d, from the sum of Gaussians in use (the diffusion profile's) or Burley's closed form.
// Used by ss_transmittance.frag and penner.frag; the thickness is lib/tr_thickness.glsl.
#ifndef LIB_TR_PROFILE_GLSL
#define LIB_TR_PROFILE_GLSL
#ifndef MAX_GAUSSIANS
#error "tr_profile.glsl needs MAX_GAUSSIANS"
#endif
uniform float u_tr_scale;          // profile distance per mm of thickness
uniform float u_tr_div;            // 1: exp(-d^2/v) printed, 2: exact
uniform int u_tr_count;
uniform vec3 u_tr_w[MAX_GAUSSIANS];
uniform float u_tr_v[MAX_GAUSSIANS];
uniform int u_tr_model;            // 0: the Gaussians above; 1: Burley closed form; 2: Burley thick (spec §5.4)
uniform vec3 u_tr_S;               // Burley: S = 1/d per channel (1/mm)

vec3 transmittance_profile(float d) {  // T(d) = sum_i w_i exp(-d^2 / (div v_i)), T(0) = sum w_i
    // Burley (spec §5.4, HDRP): int 2 pi r R(sqrt(r^2 + d^2)) dr = (e^(-S d) + 3 e^(-S d / 3)) / 4,
    // T(0) = 1; thick ("regular") mode without a baked thickness: e^(-S d / 3)
    if (u_tr_model == 1) return 0.25 * (exp(-u_tr_S * d) + 3.0 * exp(-u_tr_S * d / 3.0));
    if (u_tr_model == 2) return exp(-u_tr_S * d / 3.0);
    vec3 t = vec3(0.0);
    for (int i = 0; i < MAX_GAUSSIANS; ++i) {
        if (i >= u_tr_count) break;
        float v = u_tr_v[i];
        t += u_tr_w[i] * (v > 0.0 ? exp(-d * d / (u_tr_div * v)) : (d > 0.0 ? 0.0 : 1.0));
    }
    return t;
}
#endif
