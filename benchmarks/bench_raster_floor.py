"""What this rasteriser charges for the building blocks of texture-space diffusion, measured side by
side in one run (glFinish + wall clock, medians): the floor under issue 14's "one blur draw / a plain
copy" ratio, whether a branch no fragment takes is skipped, and what rasterising a mesh unwrapped
costs against shading the same texels in one full-screen draw.

    python benchmarks/bench_raster_floor.py [--size 512] [--repeats 15]

Rows (RGBA32F size x size target; ratios to the plain copy):
* copy: one texelFetch per texel (bench_frames' yardstick);
* 7 nearest taps: the fewest fetches any 7-tap separable Gaussian can do, with no indirection,
  stretch or filtering: the floor of the blur / copy ratio on this device;
* 7 bilinear taps (+ gutter and stretch fetches): deon_blur.frag's arithmetic;
* 7 taps by hand from 2 texel fetches each: software filtering written out;
* compute, shared row: a 128-texel row segment (+ 32-texel aprons) loaded once into shared memory,
  7 hand-filtered taps from it per texel: the usual GPU remedy for fetch-bound blurs;
* 25 bilinear fetches, always / under a branch taken by half / by no fragment / in a loop run 0 or 1
  times: whether divergent or never-taken work is skipped (it is not on llvmpipe, so shaders are
  specialised with defines instead, issue 14 item 1);
* unwrap (mesh) vs full-screen: a trivial program rasterising the default head's mesh in texture
  space at full / 1/4 / 1/16 of its triangles, against a full-screen draw: the cost of small triangles
  that TexelSurfacePass removes from per-frame texture-space shading.
"""
from __future__ import annotations

import argparse
import statistics
import time

import moderngl
import numpy as np

from skinviewer.kernel.gl import describe, headless_context

VS = """#version 330 core
void main() { vec2 p = vec2((gl_VertexID << 1) & 2, gl_VertexID & 2); gl_Position = vec4(p * 2.0 - 1.0, 0.0, 1.0); }"""
HDR = """#version 330 core
uniform sampler2D source; uniform sampler2D stretch_map; uniform sampler2D gutter; uniform float w[7];
uniform vec2 u_dir; uniform float sigma; out vec4 f;
"""
TAPS25 = "for (int y = -2; y <= 2; ++y) for (int x = -2; x <= 2; ++x) a += texture(source, (gl_FragCoord.xy + vec2(x, y) * 1.3) / vec2(textureSize(source, 0)));"
FRAGMENT = {
    "copy": "void main() { f = texelFetch(source, ivec2(gl_FragCoord.xy), 0); }",
    "7 nearest taps": """void main() { ivec2 s = ivec2(gl_FragCoord.xy); ivec2 d = ivec2(u_dir); ivec2 hi = textureSize(source, 0) - 1;
        vec4 a = vec4(0.0); for (int k = 0; k < 7; ++k) a += w[k] * texelFetch(source, clamp(s + d * (k - 3) * 4, ivec2(0), hi), 0); f = a; }""",
    "7 bilinear taps": """void main() { ivec2 s = ivec2(texelFetch(gutter, ivec2(gl_FragCoord.xy), 0).rg + 0.5);
        vec2 uv = (vec2(s) + 0.5) / vec2(textureSize(source, 0)); vec2 st = texelFetch(stretch_map, s, 0).rg * u_dir * sigma;
        vec4 a = vec4(0.0); for (int k = 0; k < 7; ++k) a += w[k] * texture(source, uv + st * float(k - 3)); f = a; }""",
    "7 taps, 2 fetches each": """void main() { ivec2 s = ivec2(texelFetch(gutter, ivec2(gl_FragCoord.xy), 0).rg + 0.5);
        float n = float(textureSize(source, 0).x); float d = dot(texelFetch(stretch_map, s, 0).rg * sigma * n, u_dir);
        ivec2 di = ivec2(u_dir); int hi = textureSize(source, 0).x - 1; int c = int(dot(vec2(s), u_dir));
        vec4 a = vec4(0.0); for (int k = 0; k < 7; ++k) { float x = float(c) + d * float(k - 3); float x0 = floor(x); int i0 = int(x0);
            vec4 t0 = texelFetch(source, s + di * (clamp(i0, 0, hi) - c), 0), t1 = texelFetch(source, s + di * (clamp(i0 + 1, 0, hi) - c), 0);
            a += w[k] * mix(t0, t1, x - x0); } f = a; }""",
    "25 taps, always": "void main() { vec4 a = vec4(0.0); " + TAPS25 + " f = a; }",
    "25 taps, branch taken by half": "void main() { vec4 a = vec4(0.0); if (gl_FragCoord.x < 0.5 * float(textureSize(source, 0).x)) { " + TAPS25 + " } f = a; }",
    "25 taps, branch taken by none": "void main() { vec4 a = vec4(0.0); if (gl_FragCoord.x < -1.0) { " + TAPS25 + " } f = a; }",
    "25 taps, loop run 0-1 times": "void main() { vec4 a = vec4(0.0); for (int j = 0; j < (gl_FragCoord.x < 0.5 * float(textureSize(source, 0).x) ? 1 : 0); ++j) { " + TAPS25 + " } f = a; }",
}
COMPUTE = """#version 430
layout(local_size_x = 128, local_size_y = 1) in;
layout(rgba32f, binding = 0) uniform writeonly image2D dst;
uniform sampler2D source; uniform sampler2D stretch_map; uniform float w[7]; uniform float sigma;
const int A = 32;
shared vec4 row[128 + 2 * A];
void main() {
    ivec2 g = ivec2(gl_GlobalInvocationID.xy); int l = int(gl_LocalInvocationID.x); int base = int(gl_WorkGroupID.x) * 128 - A;
    int hi = textureSize(source, 0).x - 1;
    for (int i = l; i < 128 + 2 * A; i += 128) row[i] = texelFetch(source, ivec2(clamp(base + i, 0, hi), g.y), 0);
    barrier();
    float d = texelFetch(stretch_map, g, 0).r * sigma * float(hi + 1);
    vec4 a = vec4(0.0); float c = float(g.x - base);
    for (int k = 0; k < 7; ++k) { float x = clamp(c + d * float(k - 3), 0.0, float(128 + 2 * A - 2)); float x0 = floor(x); int i0 = int(x0);
        a += w[k] * mix(row[i0], row[i0 + 1], x - x0); }
    imageStore(dst, g, a);
}"""
UNWRAP_VS = """#version 330 core
in vec2 in_uv; void main() { gl_Position = vec4(in_uv * 2.0 - 1.0, 0.0, 1.0); }"""
UNWRAP_FS = "#version 330 core\nout vec4 f; void main() { f = vec4(gl_FragCoord.xy, 0.0, 1.0); }"


def timed(ctx, fn) -> float:
    ctx.finish()
    t0 = time.perf_counter()
    fn()
    ctx.finish()
    return (time.perf_counter() - t0) * 1000.0


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--size", type=int, default=512)
    ap.add_argument("--repeats", type=int, default=15)
    args = ap.parse_args()
    n = args.size
    ctx = headless_context()
    rng = np.random.default_rng(0)
    src = ctx.texture((n, n), 4, rng.random((n, n, 4)).astype("f4").tobytes(), dtype="f4")
    src.repeat_x = src.repeat_y = False
    stretch = ctx.texture((n, n), 2, np.full((n, n, 2), 3.0 / n, np.float32).tobytes(), dtype="f4")
    ij = np.stack(np.meshgrid(np.arange(n), np.arange(n), indexing="xy"), -1)
    gutter = ctx.texture((n, n), 2, ij.astype("f2").tobytes(), dtype="f2")
    for t in (stretch, gutter):
        t.filter = (moderngl.NEAREST, moderngl.NEAREST)
    dst = ctx.texture((n, n), 4, dtype="f4")
    fbo = ctx.framebuffer([dst])
    src.use(0)
    stretch.use(1)
    gutter.use(2)
    weights = [0.0044, 0.054, 0.242, 0.3991, 0.242, 0.054, 0.0044]

    def setup(p):
        for name, unit in (("source", 0), ("stretch_map", 1), ("gutter", 2)):
            if name in p:
                p[name].value = unit
        for name, value in (("w", weights), ("sigma", 1.0), ("u_dir", (1.0, 0.0))):
            if name in p:
                p[name].value = value
        return p

    draws = {}
    for name, body in FRAGMENT.items():
        prog = setup(ctx.program(vertex_shader=VS, fragment_shader=HDR + body))
        vao = ctx.vertex_array(prog, [])
        draws[name] = lambda vao=vao: (fbo.use(), vao.render(vertices=3))
    cs = setup(ctx.compute_shader(COMPUTE))
    draws["compute, shared row"] = lambda: (dst.bind_to_image(0, read=False, write=True), cs.run(n // 128, n, 1))

    # the default head's mesh unwrapped, at its levels of detail
    from skinviewer.scene.head import default_head
    from skinviewer.scene.lod import decimate, level_targets
    head = default_head()
    unwrap = ctx.program(vertex_shader=UNWRAP_VS, fragment_shader=UNWRAP_FS)
    full_screen = ctx.vertex_array(ctx.program(vertex_shader=VS, fragment_shader=UNWRAP_FS), [])
    for target in level_targets(len(head.indices))[:3]:
        m = decimate(head, target)
        vbo = ctx.buffer(np.asarray(m.uvs, np.float32).tobytes())
        ibo = ctx.buffer(np.asarray(m.indices, np.int32).tobytes())
        vao = ctx.vertex_array(unwrap, [(vbo, "2f", "in_uv")], index_buffer=ibo, index_element_size=4)
        draws[f"unwrap, {len(m.indices):,} triangles"] = lambda vao=vao: (fbo.use(), vao.render())
    draws["the same texels, full-screen"] = lambda: (fbo.use(), full_screen.render(vertices=3))
    ctx.disable(moderngl.DEPTH_TEST)
    ctx.disable(moderngl.CULL_FACE)

    for fn in draws.values():  # compile / JIT
        timed(ctx, fn)
    times = {k: [] for k in draws}
    for _ in range(args.repeats):  # interleaved: load changes hit every row alike
        for k, fn in draws.items():
            times[k].append(timed(ctx, fn))
    copy = statistics.median(times["copy"])
    print(f"# {describe(ctx)}; {n}^2 RGBA32F; medians of {args.repeats} interleaved runs")
    print(f"{'draw':<36} {'ms':>8} {'/ copy':>8}")
    for k, v in times.items():
        m = statistics.median(v)
        print(f"{k:<36} {m:8.2f} {m / copy:8.2f}")


if __name__ == "__main__":
    main()
