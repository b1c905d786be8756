// The blurred irradiance textures of d'Eon & Luebke 2007 (seed 000 eq. 24) as the passes that read
// them declare them (deon_final.frag, deon_transmitted.frag), the translucent shadow map's uniforms
// and the stretch lookup of lib/tsm_transmit.glsl. The includer defines G_MASK (bit i: Gaussian i
// used) and G_TSM (the TSM code is compiled in).
#ifndef SKINVIEWER_DEON_BLURS_GLSL
#define SKINVIEWER_DEON_BLURS_GLSL
uniform int u_count;
uniform vec3 u_w[MAX_GAUSSIANS];
uniform float u_var[MAX_GAUSSIANS];      // variance (mm^2) of each blurred texture
uniform int u_used[MAX_GAUSSIANS];
uniform sampler2D blur0;
uniform sampler2D blur1;
uniform sampler2D blur2;
uniform sampler2D blur3;
uniform sampler2D blur4;
uniform sampler2D blur5;
uniform sampler2D blur6;
uniform sampler2D blur7;
uniform int u_tsm_printed;       // 1: exp(-d^2/v) as printed in seed 000 eq. (33)
uniform sampler2D tsm_map;
uniform sampler2D zone_map;      // the blurs' gutter map: B the UV island zone of a texel
uniform mat4 u_tsm_matrix;
uniform float u_tsm_gate_mm;     // own thickness under which a point counts as directly lit
uniform sampler2D stretch_map;
uniform vec2 u_uniform_stretch;
uniform int u_use_stretch;

// blur_i read here: used ones, and blur_(i-1) of a used i >= 1 for its thickness with the TSM
#define HERE_MASK (G_MASK | ((G_TSM != 0) ? (G_MASK >> 1) : 0))
#define THERE_MASK G_MASK  // the lit points A of the TSM: every used blur (lib/tsm_transmit.glsl)

// every blurred texture sampled once per point, by name: an index into a chain of samplers would
// make many compilers fetch all eight on each call; slots outside `mask` are not sampled at all
#define FETCH_ONE(out_, k, s, uv, mask) out_[k] = (((mask) >> k) & 1) != 0 ? texture(s, uv) : vec4(0.0);
#define FETCH_BLURS(out_, uv, mask) FETCH_ONE(out_, 0, blur0, uv, mask) FETCH_ONE(out_, 1, blur1, uv, mask) FETCH_ONE(out_, 2, blur2, uv, mask) FETCH_ONE(out_, 3, blur3, uv, mask) FETCH_ONE(out_, 4, blur4, uv, mask) FETCH_ONE(out_, 5, blur5, uv, mask) FETCH_ONE(out_, 6, blur6, uv, mask) FETCH_ONE(out_, 7, blur7, uv, mask)

vec2 uv_per_mm(vec2 uv) {
    vec2 s = (u_use_stretch != 0) ? texture(stretch_map, uv).rg : u_uniform_stretch;
    return max(s, vec2(1e-7));
}
#endif
