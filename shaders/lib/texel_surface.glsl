// The texel surface map (texel_surface.frag, once per mesh and size) as full-screen texture-space
// passes read it: the mesh's interpolated attributes at this fragment's texel centre (issue 14).
#ifndef SKINVIEWER_TEXEL_SURFACE_GLSL
#define SKINVIEWER_TEXEL_SURFACE_GLSL
uniform sampler2D surface_p;  // P (mesh units), dP/dx.x
uniform sampler2D surface_n;  // vertex normal, dP/dx.y
uniform sampler2D surface_t;  // tangent (w: handedness)
uniform sampler2D surface_d;  // dP/dy, dP/dx.z
struct TexelSurface { vec3 P; vec3 N; vec4 T; vec3 dPdx; vec3 dPdy; };
TexelSurface texel_surface() {
    ivec2 q = ivec2(gl_FragCoord.xy);
    vec4 p = texelFetch(surface_p, q, 0), n = texelFetch(surface_n, q, 0), d = texelFetch(surface_d, q, 0);
    return TexelSurface(p.xyz, n.xyz, texelFetch(surface_t, q, 0), vec3(p.w, n.w, d.w), d.xyz);
}
// the position alone (a pass that declares only the "p" map)
vec3 texel_position() { return texelFetch(surface_p, ivec2(gl_FragCoord.xy), 0).xyz; }
#endif
