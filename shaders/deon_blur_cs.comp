#version 430 core
// deon_blur.frag as a compute pass (issue 27, render.compute_blur): the same blur (lib/deon_blur.glsl)
// at each texel of the tiles, stored with imageStore instead of rasterised; the same values.
#include "lib/compute_target.glsl"
#include "lib/deon_blur.glsl"
void main() {
    ivec2 p;
    if (cs_texel(p))
        imageStore(u_target, p, deon_blur_at(p));
}
