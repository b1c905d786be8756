#version 330 core
// The viewer's display (ui/display.py): a full-screen triangle scaled by u_scale (letterboxing a
// texture whose aspect differs from the viewport's).
uniform vec2 u_scale;
out vec2 v_uv;
void main() {
    vec2 p = vec2(float((gl_VertexID << 1) & 2), float(gl_VertexID & 2));
    v_uv = p;
    gl_Position = vec4((p * 2.0 - 1.0) * u_scale, 0.0, 1.0);
}
