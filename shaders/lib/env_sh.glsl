// The environment light's SH irradiance (issue 32; numpy twin: physics/environment.sh_irradiance), shared
// by the vertex stage (lib/mesh_vs.glsl: the transfer vectors) and the fragment stage (lib/environment.glsl).
#ifndef SKINVIEWER_ENV_SH_GLSL
#define SKINVIEWER_ENV_SH_GLSL
uniform vec3 u_env_sh[9];  // A_l L_lm x colour x intensity (R&H 2001 eq. 7), yaw applied

// R&H 2001 eq. 13's polynomial form of sum_lm A_l L_lm Y_lm(n) (basis constants of eq. 3), >= 0
vec3 env_sh_irradiance(vec3 n) {
    float x = n.x, y = n.y, z = n.z;
    vec3 e = u_env_sh[0] * 0.282095
           + (u_env_sh[1] * y + u_env_sh[2] * z + u_env_sh[3] * x) * 0.488603
           + (u_env_sh[4] * (x * y) + u_env_sh[5] * (y * z) + u_env_sh[7] * (x * z)) * 1.092548
           + u_env_sh[6] * (0.315392 * (3.0 * z * z - 1.0)) + u_env_sh[8] * (0.546274 * (x * x - y * y));
    return max(e, vec3(0.0));
}
// the same sum split by band (pre-integrated skin scales each band: physics sh_irradiance_scattered)
void env_sh_bands(vec3 n, out vec3 b0, out vec3 b1, out vec3 b2) {
    float x = n.x, y = n.y, z = n.z;
    b0 = u_env_sh[0] * 0.282095;
    b1 = (u_env_sh[1] * y + u_env_sh[2] * z + u_env_sh[3] * x) * 0.488603;
    b2 = (u_env_sh[4] * (x * y) + u_env_sh[5] * (y * z) + u_env_sh[7] * (x * z)) * 1.092548
       + u_env_sh[6] * (0.315392 * (3.0 * z * z - 1.0)) + u_env_sh[8] * (0.546274 * (x * x - y * y));
}
#endif
