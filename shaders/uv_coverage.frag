#version 330 core
// 1 where a UV island covers the texel.
out float f_covered;
void main() { f_covered = 1.0; }
