#version 330 core
#pragma vertex_stage "vs/fullscreen.vert"
// Screen-space transmittance (seed 001 eq. 3.18, spec §6.2; [SEP] SSSSTransmittance): the lighting
// pass's direct diffuse plus, per shadow-casting light k, its weight (mask albedo^f Lc back n/9) times
// the profile at its thickness, T(d_k x scale). Only T(d) is here, so a profile edit re-runs this
// pass, not the lighting.
#include "lib/color.glsl"
#include "lib/tr_profile.glsl"
#ifndef TR_TARGETS
#define TR_TARGETS 1
#endif
uniform sampler2D direct;          // ss_diffuse_direct: rgb = E albedo^f, a = SSS mask
uniform sampler2D transmitted0;    // ss_transmitted_k: rgb = weight, a = thickness mm
uniform sampler2D transmitted1;
uniform sampler2D transmitted2;
uniform sampler2D transmitted3;
out vec4 o_diffuse;

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
