#version 330 core
// Shared vertex stage: a full-screen triangle without vertex buffers (gl_VertexID 0..2).
// Programs use it with `#pragma vertex_stage "vs/fullscreen.vert"` in their .frag.
out vec2 v_uv;
void main() {
    vec2 p = vec2((gl_VertexID << 1) & 2, gl_VertexID & 2);
    v_uv = p;
    gl_Position = vec4(p * 2.0 - 1.0, 0.0, 1.0);
}
