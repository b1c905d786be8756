#version 330 core
// Stores z/w in [0,1] (seed 000 §4.1.1 step 4).
in float v_depth;
out float f_depth;
void main() { f_depth = v_depth; }
