#version 330 core
// Gosselin light map: the mesh unwrapped into texture space (seed 000 eq. 8), camera-independent.
#include "lib/unwrap_vs.glsl"
