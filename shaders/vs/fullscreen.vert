#version 330 core
// Shared vertex stage: a full-screen triangle without vertex buffers (gl_VertexID 0..2).
// Programs use it with `#pragma vertex_stage "vs/fullscreen.vert"` in their .frag.
// TILED (issue 14, gutters): instead, two triangles per tile of a list (u_tiles: one row of RG =
// tile origin in texels; 6 vertices per tile), so only the listed tiles are rasterised at all.
// TILED == 2: the list holds rectangles (RGBA = x, y, w, h in texels, texture_space.tile_rects).
out vec2 v_uv;
#ifdef TILED
uniform sampler2D u_tiles;
uniform float u_tile;          // tile edge, texels
uniform vec2 u_target_size;    // texels
const vec2 CORNERS[6] = vec2[6](vec2(0, 0), vec2(1, 0), vec2(1, 1), vec2(0, 0), vec2(1, 1), vec2(0, 1));
#endif
void main() {
#ifdef TILED
#if TILED == 2
    vec4 rect = texelFetch(u_tiles, ivec2(gl_VertexID / 6, 0), 0);
    vec2 p = min((rect.xy + CORNERS[gl_VertexID % 6] * rect.zw) / u_target_size, vec2(1.0));
#else
    vec2 origin = texelFetch(u_tiles, ivec2(gl_VertexID / 6, 0), 0).rg;
    vec2 p = min((origin + CORNERS[gl_VertexID % 6] * u_tile) / u_target_size, vec2(1.0));
#endif
#else
    vec2 p = vec2((gl_VertexID << 1) & 2, gl_VertexID & 2);
#endif
    v_uv = p;
    gl_Position = vec4(p * 2.0 - 1.0, 0.0, 1.0);
}
