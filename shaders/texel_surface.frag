#version 330 core
#pragma vertex_stage "vs/unwrap.vert"
// The texel surface map (issue 14): the mesh's interpolated attributes at every covered texel
// centre, rasterised once per mesh and size, so per-frame texture-space shading (deon_irradiance_
// texels.frag) is a full-screen draw. Derivatives are the unwrap's own (one texel per pixel).
// A NaN or Inf attribute (a broken mesh) is stored as 0: the map stays finite, and the shading that
// reads it sees a zero-length vector, which it treats like the NaN it stands for (no light).
in vec3 v_position;
in vec3 v_normal;
in vec2 v_uv;
in vec4 v_tangent;
layout(location = 0) out vec4 f_p;
layout(location = 1) out vec4 f_n;
layout(location = 2) out vec4 f_t;
layout(location = 3) out vec4 f_d;
vec4 finite_or_0(vec4 v) {
    return mix(v, vec4(0.0), bvec4(isnan(v.x) || isinf(v.x), isnan(v.y) || isinf(v.y),
                                   isnan(v.z) || isinf(v.z), isnan(v.w) || isinf(v.w)));
}
void main() {
    vec3 dx = dFdx(v_position), dy = dFdy(v_position);
    f_p = finite_or_0(vec4(v_position, dx.x));
    f_n = finite_or_0(vec4(v_normal, dx.y));
    f_t = finite_or_0(v_tangent);
    f_d = finite_or_0(vec4(dy, dx.z));
}
