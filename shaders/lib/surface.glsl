// Surface inputs from the mesh's maps (albedo linear, tangent-space normal map).
#ifndef SKINVIEWER_SURFACE_GLSL
#define SKINVIEWER_SURFACE_GLSL
uniform sampler2D albedo_map;   // linear RGB
uniform sampler2D normal_map;   // tangent space, n * 0.5 + 0.5
uniform int u_has_normal_map;

vec3 surface_normal(vec3 n, vec4 t, vec2 uv) {
    vec3 N = normalize(n);
    if (u_has_normal_map == 0) return N;
    vec3 T = t.xyz - N * dot(N, t.xyz);
    float tl = length(T);
    if (tl < 1e-6) return N;
    T /= tl;
    vec3 B = cross(N, T) * (t.w < 0.0 ? -1.0 : 1.0);
    vec3 m = texture(normal_map, uv).xyz * 2.0 - 1.0;
    vec3 P = T * m.x + B * m.y + N * m.z;
    float pl = length(P);
    return pl > 1e-6 ? P / pl : N;
}
#endif
