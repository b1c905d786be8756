"""Issue 27: is a compute-shader sliding window faster than the fragment blur on this GL? One synthetic
blur direction of d'Eon's shape (7 bilinear taps whose spacing is a per-texel stretch fetch, RGBA32F,
the map size) in plain full-screen copies of the same size and format, side by side in one run:

- fragment, one full-screen triangle / 70 % of 16^2 tiles as one quad each / those tiles merged into
  row runs (texture_space.tile_rects' idea);
- compute, a row segment plus its apron loaded once into shared memory, every tap interpolated by hand
  from there (the "sliding window"), for a few workgroup shapes;
- compute, the same taps through texture() over the tile list (no triangles at all).

    python benchmarks/bench_compute_blur.py [--maps 1024] [--repeats 5]

Sync timing (glFinish + wall clock), medians. Needs GL 4.3 for the compute rows (skipped otherwise).
Each row's output is checked against the fragment whole-map blur on the texels it writes (max |difference|
printed; texture() taps must agree within 1e-6, the hand-interpolated windows within 4e-3: a GPU's
bilinear filter keeps ~8 bits of the fraction).
On llvmpipe (2 cores, load 1-3) the fragment path won: whole 3.6-4.6 copies, runs 3.4-3.5, shared-memory
windows 7.4-27, compute texture() 12-14 (notes/perf.md).
"""
from __future__ import annotations

import argparse
import statistics
import time

import moderngl
import numpy as np

W7 = "const float w[7] = float[](0.006, 0.061, 0.242, 0.383, 0.242, 0.061, 0.006);"
VS = "#version 330\nvoid main(){vec2 p=vec2((gl_VertexID<<1)&2, gl_VertexID&2);gl_Position=vec4(p*2.0-1.0,0,1);}"
VS_RECTS = """#version 330
uniform sampler2D u_rects; uniform vec2 u_target_size;
const vec2 C[6] = vec2[6](vec2(0, 0), vec2(1, 0), vec2(1, 1), vec2(0, 0), vec2(1, 1), vec2(0, 1));
void main(){ vec4 r = texelFetch(u_rects, ivec2(gl_VertexID / 6, 0), 0);
 vec2 p = min((r.xy + C[gl_VertexID % 6] * r.zw) / u_target_size, vec2(1.0)); gl_Position=vec4(p*2.0-1.0,0,1);}"""
COPY = "#version 330\nuniform sampler2D s;out vec4 o;void main(){o=texelFetch(s,ivec2(gl_FragCoord.xy),0);}"
BODY = """
 vec2 ts=vec2(textureSize(s,0)); vec2 uv=(vec2(p)+0.5)/ts;
 vec2 stp = vec2(texelFetch(st,p,0).r*sig/ts.x, 0.0); vec4 a=vec4(0);
 for(int k=0;k<7;++k) a+=w[k]*texture(s, uv+stp*float(k-3));"""
FRAG = f"#version 330\nuniform sampler2D s; uniform sampler2D st; uniform float sig; out vec4 o;{W7}\n" \
       f"void main(){{ ivec2 p=ivec2(gl_FragCoord.xy);{BODY} o=a; }}"


def window_cs(w: int, apron: int, lx: int) -> str:
    """A row segment of w texels + apron in shared memory; taps interpolated by hand from it."""
    rw = w + 2 * apron
    return f"""#version 430
layout(local_size_x={lx}) in;
layout(rgba32f, binding=0) writeonly uniform image2D dst;
uniform sampler2D s; uniform sampler2D st; uniform float sig; {W7}
shared vec4 sh[{rw}];
vec4 at(int x, int o) {{ return sh[clamp(x - o, 0, {rw - 1})]; }}
void main() {{
  ivec2 n = textureSize(s, 0);
  int base = int(gl_WorkGroupID.x) * {w}, y = int(gl_WorkGroupID.y), o = base - {apron};
  for (int x = int(gl_LocalInvocationID.x); x < {rw}; x += {lx})
    sh[x] = texelFetch(s, ivec2(clamp(o + x, 0, n.x - 1), y), 0);
  barrier();
  for (int x = int(gl_LocalInvocationID.x); x < {w}; x += {lx}) {{
    ivec2 p = ivec2(base + x, y);
    float stp = texelFetch(st, p, 0).r * sig;
    vec4 a = vec4(0);
    for (int k = 0; k < 7; ++k) {{
      float t = float(p.x) + stp * float(k - 3); float f = floor(t); int i = int(f);
      a += w[k] * mix(at(i, o), at(i + 1, o), t - f);
    }}
    imageStore(dst, p, a);
  }}
}}"""


def tiles_cs(tile: int, lx: int, ly: int) -> str:
    per = tile * tile // (lx * ly)
    return f"""#version 430
layout(local_size_x={lx}, local_size_y={ly}) in;
layout(rgba32f, binding=0) writeonly uniform image2D dst;
uniform sampler2D s; uniform sampler2D st; uniform sampler2D u_tiles; uniform float sig; {W7}
void main() {{
  ivec2 o = ivec2(texelFetch(u_tiles, ivec2(gl_WorkGroupID.x, 0), 0).rg);
  for (int j = 0; j < {per}; ++j) {{
    int li = int(gl_LocalInvocationIndex) + j * {lx * ly};
    ivec2 p = o + ivec2(li % {tile}, li / {tile});
    {BODY}
    imageStore(dst, p, a);
  }}
}}"""


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--maps", type=int, default=1024)
    ap.add_argument("--repeats", type=int, default=5)
    args = ap.parse_args()
    from skinviewer.kernel.gl import describe, headless_context
    from skinviewer.passes.texture_space import tile_rects
    try:  # compute needs GL 4.3: a driver gives exactly the version asked for (NVIDIA's EGL gave 3.3)
        ctx = headless_context(430)
    except Exception:  # noqa: BLE001  (no 4.3 context: the fragment rows only)
        ctx = headless_context()
    n, tile = args.maps, 16
    rng = np.random.default_rng(0)
    src = ctx.texture((n, n), 4, rng.random((n, n, 4), dtype=np.float32).tobytes(), dtype="f4")
    dst = ctx.texture((n, n), 4, dtype="f4")
    stretch = np.tile(np.float32([1.0, 1.2, 0.1, 1.0]), (n, n, 1))
    stretch[..., 0] = 0.8 + 0.4 * rng.random((n, n), dtype=np.float32)  # taps between texels: filtering is checked
    st = ctx.texture((n, n), 4, stretch.tobytes(), dtype="f4")
    st.filter = (moderngl.NEAREST, moderngl.NEAREST)
    nt = n // tile
    sel = (rng.random((nt, nt)) < 0.7)
    ty, tx = np.nonzero(sel)
    tiles = ctx.texture((len(tx), 1), 2, np.stack([tx * tile, ty * tile], 1).astype(np.float32).tobytes(), dtype="f4")
    boxes = (tile_rects(sel) * tile).astype(np.float32)
    rects = ctx.texture((len(boxes), 1), 4, boxes.tobytes(), dtype="f4")
    quads = np.stack([tx * tile, ty * tile, np.full_like(tx, tile), np.full_like(tx, tile)], 1).astype(np.float32)
    quad_tex = ctx.texture((len(quads), 1), 4, quads.tobytes(), dtype="f4")
    for t in (tiles, rects, quad_tex):
        t.filter = (moderngl.NEAREST, moderngl.NEAREST)
    fbo = ctx.framebuffer([dst])

    def timed(fn) -> float:
        fn()
        ctx.finish()
        ts = []
        for _ in range(args.repeats):
            ctx.finish()
            t0 = time.perf_counter()
            fn()
            ctx.finish()
            ts.append((time.perf_counter() - t0) * 1000.0)
        return statistics.median(ts)

    def frag(vs: str, fs: str, vertices: int, rect_tex=None):
        prog = ctx.program(vertex_shader=vs, fragment_shader=fs)
        vao = ctx.vertex_array(prog, [])

        def run():
            fbo.use()
            src.use(0)
            st.use(1)
            for name, unit in (("s", 0), ("st", 1), ("sig", None), ("u_rects", 2), ("u_target_size", None)):
                if name in prog:
                    prog[name].value = {"sig": 4.0, "u_target_size": (n, n)}.get(name, unit)
            if rect_tex is not None:
                rect_tex.use(2)
            vao.render(vertices=vertices)
        return run

    copy = timed(frag(VS, COPY, 3))
    print(f"# {describe(ctx)}; {n}^2 RGBA32F; plain copy {copy:.2f} ms; {len(tx)} tiles = {len(boxes)} rectangles")
    src.filter = (moderngl.LINEAR, moderngl.LINEAR)
    src.repeat_x = src.repeat_y = False  # clamped at the map's edge, as the windows' loads
    rows = [("fragment, whole map", frag(VS, FRAG, 3)),
            ("fragment, one quad per tile", frag(VS_RECTS, FRAG, 6 * len(quads), quad_tex)),
            ("fragment, tiles merged into rectangles", frag(VS_RECTS, FRAG, 6 * len(boxes), rects))]
    if ctx.version_code >= 430:
        for w, apron, lx in ((256, 16, 64), (256, 16, 256), (512, 16, 512)):
            if n % w:  # a window per row segment: the map must be whole segments
                continue
            cs = ctx.compute_shader(window_cs(w, apron, lx))

            def run(cs=cs, w=w):
                dst.bind_to_image(0, read=False, write=True)
                src.use(0)
                st.use(1)
                cs["s"], cs["st"], cs["sig"] = 0, 1, 4.0
                cs.run(n // w, n)
            rows.append((f"compute window {w}+2x{apron} texels, {lx} invocations", run))
        cs = ctx.compute_shader(tiles_cs(tile, 16, 4))

        def run_t():
            dst.bind_to_image(0, read=False, write=True)
            src.use(0)
            st.use(1)
            tiles.use(2)
            cs["s"], cs["st"], cs["u_tiles"], cs["sig"] = 0, 1, 2, 4.0
            cs.run(len(tx), 1)
        rows.append(("compute texture() taps over the tiles", run_t))
    # each row's output against the fragment whole-map blur's, on the texels it writes (the tiles for the
    # tiled rows, the whole map else), after clearing the target to -1 so a texel left unwritten shows
    tile_mask = np.kron(sel, np.ones((tile, tile), bool))
    ref = None
    worst = 0.0
    for label, fn in rows:
        fbo.clear(-1.0, -1.0, -1.0, -1.0)
        fn()
        ctx.memory_barrier()
        ctx.finish()
        out = np.frombuffer(dst.read(), np.float32).reshape(n, n, 4)
        if ref is None:
            ref = out.copy()
        where = tile_mask if ("tile" in label or "rectangles" in label) else np.ones((n, n), bool)
        diff = float(np.abs(out[where] - ref[where]).max())
        # hand-interpolated windows: a GPU's bilinear filter keeps ~8 bits of the fraction, so they differ
        # from texture() by up to ~1/512 of the texel step; texture() taps: the same filter as the fragment
        tol = 4e-3 if "window" in label else 1e-6
        worst = max(worst, diff / tol)
        print(f"{label:<48} {timed(fn) / copy:6.2f} copies   max |out - fragment| {diff:.2e}"
              f"{'' if diff <= tol else f'  OVER {tol:.0e}'}")
    print(f"# outputs checked against the fragment whole-map blur: {'all within' if worst <= 1.0 else 'NOT all within'}"
          " tolerance (texture() taps 1e-6, hand-interpolated windows 4e-3)")


if __name__ == "__main__":
    main()
