#version 330 core
#pragma vertex_stage "vs/unwrap.vert"
// Texture-space position (mesh units) of each covered texel; A = 1 inside the islands. Used once
// per mesh and size to build the seam indirection of the gutter map (scene/texels.py).
in vec3 v_position;
in vec3 v_normal;
in vec2 v_uv;
in vec4 v_tangent;
out vec4 f_position;
void main() { f_position = vec4(v_position, 1.0); }
