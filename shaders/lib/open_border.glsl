// The light past an open mesh border in d'Eon's incremental blur chain (issue 30 item 5; numpy twin:
// physics/open_border.py). blur_i = G(v_i - v_(i-1)) * blur_(i-1) (seed 000 eq. 24) needs blur_(i-1)
// past the border too: there it is the odd reflection about its border value E / 2,
// blur_(i-1)(-d) = E - blur_(i-1)(d) (exact across a straight border of uniform light), kept in [0, E / 2].
// border_map (passes/deon.BorderFramePass, scene/texels.border_frame): R the signed distance (texels)
// to the island's nearest mesh border, > 0 inside; GB the inward unit normal (texels); A 1 where known.
#ifndef SKINVIEWER_OPEN_BORDER_GLSL
#define SKINVIEWER_OPEN_BORDER_GLSL
uniform sampler2D border_map;
uniform sampler2D irradiance_map;  // E: what blur 0 blurs
// E / 2 on the border at the foot of uv ``p``, ``s`` texels from it along the inward normal ``nrm``
vec3 border_half_e(vec2 p, float s, vec2 nrm) {
    return max(0.5 * texture(irradiance_map, p - s * nrm / vec2(textureSize(irradiance_map, 0))).rgb, vec3(0.0));
}
// blur_(i-1) (``src``) at uv ``p``, ``s`` texels past the border (s < 0) along the inward normal ``nrm``,
// from E / 2 on the border (border_half_e) and the value |s| inside (the mirror point; its A too)
vec4 past_border_light(sampler2D src, vec2 p, float s, vec2 nrm, vec3 half_e) {
    vec4 mirror = texture(src, p - 2.0 * s * nrm / vec2(textureSize(src, 0)));
    return vec4(clamp(2.0 * half_e - mirror.rgb, vec3(0.0), half_e), mirror.a);
}
#endif
