#version 330 core
#include "lib/unwrap_vs.glsl"
