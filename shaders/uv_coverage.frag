#version 330 core
#pragma vertex_stage "vs/unwrap.vert"
// 1 where a UV island covers the texel.
out float f_covered;
void main() { f_covered = 1.0; }
