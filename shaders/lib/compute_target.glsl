// A compute twin of a full-screen fragment pass (issue 27, notes/gpu_compute.md): one invocation per
// output texel, written with imageStore into the graph's texture (ExecuteContext.dispatch binds it to
// image unit 0). CS_TILE x CS_TILE invocations a workgroup; IMAGE_FORMAT the target's image format
// (rgba32f / rg32f: ExecuteContext.dispatch checks it against the texture).
// CS_TILES: one workgroup per tile of a list (u_tiles: RG = tile origin in texels, the texture read row
// by row, the fragment pass's tiles cut into CS_TILE x CS_TILE, sorted by y), else one per CS_TILE x CS_TILE block from the
// clip rectangle's corner. u_clip = (x0, y0, x1, y1): the band's rows and the target (the fragment
// draw's scissor and viewport): texels outside it are not written.
#ifndef SKINVIEWER_COMPUTE_TARGET_GLSL
#define SKINVIEWER_COMPUTE_TARGET_GLSL
layout(local_size_x = CS_TILE, local_size_y = CS_TILE) in;
layout(binding = 0, IMAGE_FORMAT) uniform writeonly image2D u_target;
uniform ivec4 u_clip;
#ifdef CS_TILES
uniform sampler2D u_tiles;
uniform int u_tile_first;  // this dispatch's tiles: u_tile_count of them from u_tile_first (a band's rows)
uniform int u_tile_count;
#endif
// this invocation's output texel p, and whether it is to be written
bool cs_texel(out ivec2 p) {
#ifdef CS_TILES
    int i = int(gl_WorkGroupID.y * gl_NumWorkGroups.x + gl_WorkGroupID.x);
    if (i >= u_tile_count) {  // the last row of workgroups' padding
        p = ivec2(-1);
        return false;
    }
    i += u_tile_first;
    int w = textureSize(u_tiles, 0).x;
    p = ivec2(texelFetch(u_tiles, ivec2(i % w, i / w), 0).rg) + ivec2(gl_LocalInvocationID.xy);
#else
    p = u_clip.xy + ivec2(gl_GlobalInvocationID.xy);
#endif
    return all(greaterThanEqual(p, u_clip.xy)) && all(lessThan(p, u_clip.zw));
}
#endif
