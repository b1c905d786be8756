// The vertex layout of every mesh pass (skinviewer.mesh.VERTEX_FORMAT).
#ifndef SKINVIEWER_MESH_VS_GLSL
#define SKINVIEWER_MESH_VS_GLSL
in vec3 in_position;
in vec3 in_normal;
in vec2 in_uv;
in vec4 in_tangent;
#if defined(ENV_LIGHT) && ENV_LIGHT && defined(ENV_RAYS) && ENV_RAYS > 0
// The environment light's baked visibility per vertex: the shadowed diffuse transfer vector
// T_lm = int V(w) max(N.w, 0) Y_lm(w) dw, l <= 4 (Sloan et al. 2002; GpuScene.env_visibility_buffer,
// physics/environment.bake_transfer), 25 floats in 7 vec4 (a second buffer, bound only where a program
// reads it). Out: the vertex's shadowed irradiance and its ambient occlusion (lib/environment.glsl).
#include "env_sh.glsl"
#ifndef ENV_TRANSFER
#define ENV_TRANSFER 4
#endif
uniform vec3 u_env_L[25];  // L_lm x colour x intensity at the yaw (radiance, not A_l L_lm), l <= ENV_TRANSFER
in vec4 in_env_t0;
in vec4 in_env_t1;
in vec4 in_env_t2;
in vec4 in_env_t3;
in vec4 in_env_t4;
in vec4 in_env_t5;
in vec4 in_env_t6;
out vec4 v_env_vis;
out vec2 v_env_thick;  // the thickness along -N (mesh units) and the back point's AO (bake_thickness)
vec4 env_vertex_light(vec3 Nv) {
    float T[28] = float[28](in_env_t0.x, in_env_t0.y, in_env_t0.z, in_env_t0.w, in_env_t1.x, in_env_t1.y,
        in_env_t1.z, in_env_t1.w, in_env_t2.x, in_env_t2.y, in_env_t2.z, in_env_t2.w, in_env_t3.x, in_env_t3.y,
        in_env_t3.z, in_env_t3.w, in_env_t4.x, in_env_t4.y, in_env_t4.z, in_env_t4.w, in_env_t5.x, in_env_t5.y,
        in_env_t5.z, in_env_t5.w, in_env_t6.x, in_env_t6.y, in_env_t6.z, in_env_t6.w);
    float ao = clamp(T[0] / (3.14159265 * 0.282095), 0.0, 1.0);  // T_00 / (pi Y_00)
#if ENV_TRANSFER > 0
    // Sloan et al. 2002 eq. 4 (diffuse shadowed transfer): E = sum_lm L_lm T_lm
    vec3 e = vec3(0.0);
    for (int k = 0; k < (ENV_TRANSFER + 1) * (ENV_TRANSFER + 1); ++k) e += u_env_L[k] * T[k];
    return vec4(max(e, vec3(0.0)), ao);
#else
    // ambient occlusion x SH irradiance at the bent normal (T_11, T_1-1, T_10)
    vec3 b = vec3(T[3], T[1], T[2]);
    float l = length(b);
    return vec4(ao * env_sh_irradiance(l > 1e-9 ? b / l : normalize(Nv)), ao);
#endif
}
#define ENV_VIS_OUT() v_env_vis = env_vertex_light(in_normal); v_env_thick = in_env_t6.yz
#else
#define ENV_VIS_OUT()
#endif
#endif
