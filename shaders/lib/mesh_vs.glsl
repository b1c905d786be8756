// The vertex layout of every mesh pass (skinviewer.mesh.VERTEX_FORMAT).
#ifndef SKINVIEWER_MESH_VS_GLSL
#define SKINVIEWER_MESH_VS_GLSL
in vec3 in_position;
in vec3 in_normal;
in vec2 in_uv;
in vec4 in_tangent;
#endif
