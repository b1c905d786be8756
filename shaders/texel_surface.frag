#version 330 core
#pragma vertex_stage "vs/unwrap.vert"
// The texel surface map (issue 14): the mesh's interpolated attributes at every covered texel
// centre, rasterised once per mesh and size, so per-frame texture-space shading (deon_irradiance_
// texels.frag) is a full-screen draw. Derivatives are the unwrap's own (one texel per pixel).
in vec3 v_position;
in vec3 v_normal;
in vec2 v_uv;
in vec4 v_tangent;
layout(location = 0) out vec4 f_p;
layout(location = 1) out vec4 f_n;
layout(location = 2) out vec4 f_t;
layout(location = 3) out vec4 f_d;
void main() {
    vec3 dx = dFdx(v_position), dy = dFdy(v_position);
    f_p = vec4(v_position, dx.x);
    f_n = vec4(v_normal, dx.y);
    f_t = v_tangent;
    f_d = vec4(dy, dx.z);
}
