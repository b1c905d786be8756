#version 330 core
#pragma vertex_stage "vs/unwrap.vert"
// The texel surface map (issue 14): the mesh's interpolated attributes at every covered texel
// centre, rasterised once per mesh and size, so per-frame texture-space shading (deon_irradiance_
// texels.frag) is a full-screen draw. Two RGBA32F maps:
//   p: position (mesh units), tangent handedness (+-1; 0 where no island covers the texel)
//   n: the vertex normal's and the tangent's directions, octahedral (Cigolle et al. 2014)
// The shading normalises both (lib/surface.glsl), so their directions are all it needs; the
// position's change per texel (beam footprints) comes from the neighbouring texels.
// A NaN, Inf or zero vector (a broken mesh) is stored as the code (2, 2), read back as 0: the
// shading sees a zero-length vector, which it treats like the NaN it stands for (no light).
#define TEXEL_SURFACE_WRITER
#include "lib/texel_surface.glsl"
in vec3 v_position;
in vec3 v_normal;
in vec2 v_uv;
in vec4 v_tangent;
layout(location = 0) out vec4 f_p;
layout(location = 1) out vec4 f_n;
#if defined(ENV_LIGHT) && ENV_LIGHT && defined(ENV_RAYS) && ENV_RAYS > 0
in vec4 v_env_vis;
layout(location = 2) out vec4 f_v;  // the vertex's shadowed environment irradiance + AO (issue 32, lib/mesh_vs.glsl)
#endif
void main() {
    bool bad = any(isnan(v_position)) || any(isinf(v_position));
    f_p = vec4(bad ? vec3(0.0) : v_position, v_tangent.w < 0.0 ? -1.0 : 1.0);
    f_n = vec4(oct_encode(v_normal), oct_encode(v_tangent.xyz));
#if defined(ENV_LIGHT) && ENV_LIGHT && defined(ENV_RAYS) && ENV_RAYS > 0
    f_v = v_env_vis;
#endif
}
