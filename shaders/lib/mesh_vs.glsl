// The vertex layout of every mesh pass (skinviewer.mesh.VERTEX_FORMAT).
in vec3 in_position;
in vec3 in_normal;
in vec2 in_uv;
in vec4 in_tangent;
