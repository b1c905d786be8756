// The texel surface map (texel_surface.frag, once per mesh and size) as full-screen texture-space
// passes read it: the mesh's interpolated attributes at this fragment's texel centre (issue 14).
#ifndef SKINVIEWER_TEXEL_SURFACE_GLSL
#define SKINVIEWER_TEXEL_SURFACE_GLSL
// a direction as 2 floats (octahedral, Cigolle et al. 2014); (2, 2): none (zero, NaN or Inf)
vec2 oct_encode(vec3 v) {
    float l1 = abs(v.x) + abs(v.y) + abs(v.z);
    // isnan spelled out: NVIDIA's compiler folds !(l1 > 0.0) into l1 <= 0.0, which lets a NaN through
    if (isnan(l1) || isinf(l1) || l1 <= 0.0) return vec2(2.0);
    v /= l1;
    vec2 s = vec2(v.x >= 0.0 ? 1.0 : -1.0, v.y >= 0.0 ? 1.0 : -1.0);
    return (v.z >= 0.0) ? v.xy : (1.0 - abs(v.yx)) * s;
}
vec3 oct_decode(vec2 e) {
    if (e.x > 1.5) return vec3(0.0);
    vec3 v = vec3(e, 1.0 - abs(e.x) - abs(e.y));
    vec2 s = vec2(v.x >= 0.0 ? 1.0 : -1.0, v.y >= 0.0 ? 1.0 : -1.0);
    if (v.z < 0.0) v.xy = (1.0 - abs(v.yx)) * s;
    return normalize(v);
}
#ifndef TEXEL_SURFACE_WRITER
uniform sampler2D surface_p;  // position (mesh units), tangent handedness (0: not covered)
uniform sampler2D surface_n;  // octahedral vertex normal (xy) and tangent (zw)
#if defined(ENV_TEXELS) && ENV_TEXELS
uniform sampler2D surface_v;  // the vertex's shadowed environment irradiance + AO (lib/environment.glsl ENV_VIS_IN)
#endif
struct TexelSurface { vec3 P; vec3 N; vec4 T; vec3 dPdx; vec3 dPdy; };
// the position's change per texel step: the difference to a covered neighbour (forward, else
// backward; 0 when neither side is covered)
vec4 covered_texel(ivec2 q) {  // w = 0 outside the map or the islands
    ivec2 hi = textureSize(surface_p, 0) - 1;
    return (q == clamp(q, ivec2(0), hi)) ? texelFetch(surface_p, q, 0) : vec4(0.0);
}
vec3 texel_step(ivec2 q, ivec2 d, vec3 P) {
    vec4 f = covered_texel(q + d), b = covered_texel(q - d);
    return (f.w != 0.0) ? f.xyz - P : ((b.w != 0.0) ? P - b.xyz : vec3(0.0));
}
// TEXEL_STEPS (a beam light is on: its footprint needs them) or zero steps
TexelSurface texel_surface() {
    ivec2 q = ivec2(gl_FragCoord.xy);
    vec4 p = texelFetch(surface_p, q, 0), n = texelFetch(surface_n, q, 0);
#if defined(TEXEL_STEPS) && TEXEL_STEPS
    vec3 dx = texel_step(q, ivec2(1, 0), p.xyz), dy = texel_step(q, ivec2(0, 1), p.xyz);
#else
    vec3 dx = vec3(0.0), dy = vec3(0.0);
#endif
    return TexelSurface(p.xyz, oct_decode(n.xy), vec4(oct_decode(n.zw), p.w), dx, dy);
}
// the position alone (a pass that declares only the "p" map)
vec3 texel_position() { return texelFetch(surface_p, ivec2(gl_FragCoord.xy), 0).xyz; }
#endif
#endif
