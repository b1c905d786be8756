#version 330 core
#pragma vertex_stage "vs/fullscreen.vert"
// Screen-space transmittance (seed 001 eq. 3.18, spec §6.2; [SEP] SSSSTransmittance): the lighting
// pass's direct diffuse plus, per shadow-casting light k, its weight (mask albedo^f Lc back n/9) times
// the profile at its thickness, T(d_k x scale). Only T(d) is here, so a profile edit re-runs this
// pass, not the lighting.
#include "lib/color.glsl"
#ifndef TR_TARGETS
#define TR_TARGETS 1
#endif
uniform sampler2D direct;          // ss_diffuse_direct: rgb = E albedo^f, a = SSS mask
uniform sampler2D transmitted0;    // ss_transmitted_k: rgb = weight, a = thickness mm
uniform sampler2D transmitted1;
uniform sampler2D transmitted2;
uniform sampler2D transmitted3;
uniform float u_tr_scale;          // profile distance per mm of thickness
uniform float u_tr_div;            // 1: exp(-d^2/v) printed, 2: exact
uniform int u_tr_count;
uniform vec3 u_tr_w[MAX_GAUSSIANS];
uniform float u_tr_v[MAX_GAUSSIANS];
uniform int u_tr_model;            // 0: the Gaussians above; 1: Burley closed form; 2: Burley thick (spec §5.4)
uniform vec3 u_tr_S;               // Burley: S = 1/d per channel (1/mm)
out vec4 o_diffuse;

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

vec3 through(vec4 t) {  // weight x T(thickness x scale); nothing where no light came through
    return any(greaterThan(t.rgb, vec3(0.0))) ? t.rgb * transmittance_profile(t.a * u_tr_scale) : vec3(0.0);
}

void main() {
    ivec2 p = ivec2(gl_FragCoord.xy);
    vec4 D = texelFetch(direct, p, 0);
    vec3 T = through(texelFetch(transmitted0, p, 0));
#if TR_TARGETS > 1
    T += through(texelFetch(transmitted1, p, 0));
#endif
#if TR_TARGETS > 2
    T += through(texelFetch(transmitted2, p, 0));
#endif
#if TR_TARGETS > 3
    T += through(texelFetch(transmitted3, p, 0));
#endif
    o_diffuse = finite4_f32(vec4(D.rgb + T, D.a));
}
