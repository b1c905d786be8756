#version 330 core
// The texture-space unwrap (vs/unwrap.vert) that also passes the per-vertex UV covariance of a unit
// surface Gaussian (physics/diffusion.vertex_uv_covariance) to the stretch map (deon_stretch.frag).
#include "../lib/mesh_vs.glsl"
in vec3 in_uv_covariance;
out vec3 v_position;
out vec2 v_uv;
out vec3 v_uv_cov;
void main() {
    v_position = in_position;
    v_uv = in_uv;
    v_uv_cov = in_uv_covariance;
    gl_Position = vec4(in_uv * 2.0 - 1.0, 0.0, 1.0);
}
