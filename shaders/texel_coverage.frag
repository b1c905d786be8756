#version 330 core
#pragma vertex_stage "vs/fullscreen.vert"
// 1 where a UV island covers the texel, read from the texel surface map (its w: the tangent's
// handedness, 0 where nothing was rasterised): the gutter map's coverage without a second raster.
uniform sampler2D surface_p;
out float f_covered;
void main() { f_covered = (texelFetch(surface_p, ivec2(gl_FragCoord.xy), 0).w != 0.0) ? 1.0 : 0.0; }
