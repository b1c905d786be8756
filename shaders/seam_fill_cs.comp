#version 430 core
// seam_fill.frag as a compute pass (issue 27, render.compute_blur): the same fill (lib/seam_fill.glsl)
// at each texel of the tiles, stored with imageStore; the same values.
#include "lib/compute_target.glsl"
#include "lib/seam_fill.glsl"
void main() {
    ivec2 p;
    if (cs_texel(p))
        imageStore(u_target, p, seam_fill_at(p));
}
