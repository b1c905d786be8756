// The vertex layout of every mesh pass (skinviewer.mesh.VERTEX_FORMAT).
#ifndef SKINVIEWER_MESH_VS_GLSL
#define SKINVIEWER_MESH_VS_GLSL
in vec3 in_position;
in vec3 in_normal;
in vec2 in_uv;
in vec4 in_tangent;
#if defined(ENV_LIGHT) && ENV_LIGHT && defined(ENV_RAYS) && ENV_RAYS > 0
// the environment light's baked visibility per vertex (bent normal, AO; GpuScene.env_visibility_buffer),
// a second buffer bound only where a program reads it
in vec4 in_env_vis;
out vec4 v_env_vis;
#define ENV_VIS_OUT() v_env_vis = in_env_vis
#else
#define ENV_VIS_OUT()
#endif
#endif
