// The direct gather's surface (deon_gather_surface.frag). A gutter texel past a mesh border (w < 0)
// at d < 0.5 texels from it is on the surface over 0.5 - d of its width; seam_fill.frag gave it
// (1 - 2d) of the edge's light (for bilinear taps), so a point sum takes half of that.
#ifndef SKINVIEWER_GATHER_SURFACE_GLSL
#define SKINVIEWER_GATHER_SURFACE_GLSL
#define PAST_BORDER_SHARE 0.5
#endif
