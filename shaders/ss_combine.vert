#version 330 core
#include "lib/fullscreen_vs.glsl"
