"""The two session-9 cuts of the summed step and the diffuse sum (issue 27; notes/deon_light_move.md section
12), each draw against its predecessor on the same textures, many times interleaved in one process (the
per-draw figures of bench_deon_draws.py swing by a third between repeats on a shared 2-core machine):

- deon_combine with BLUR_SOURCES (a texture two used slots share fetched once) | without (every slot fetched);
- the summed step's seam fill as seam tiles + NO_SEAM plain-copy tiles (passes.deon.seam_split over the whole
  map) | one draw over the whole map.

    python benchmarks/bench_sum_cuts.py [--maps 1024] [--repeats 31] [--scan]

Renders d'Eon once at the defaults (head, or the shared scan with --scan: bench_fidelity.SCAN_VALUES), then
times each pair's draws (glFinish on both sides, medians) into scratch targets, and checks that each pair
writes the same bytes. Also prints a plain RGBA32F copy of the map size for scale.
"""
from __future__ import annotations

import argparse
import os
import statistics
import sys
import time

sys.path.insert(0, os.path.dirname(__file__))
sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))

import moderngl  # noqa: E402
import numpy as np  # noqa: E402
from bench_fidelity import SCAN_VALUES  # noqa: E402
from bench_frames import copy_draw_ms, settings_for  # noqa: E402

import skinviewer.passes.deon as deon_passes  # noqa: E402
from skinviewer.engine.renderer import Renderer  # noqa: E402
from skinviewer.kernel.gl import describe, headless_context  # noqa: E402
from skinviewer.passes.texture_space import seam_resource  # noqa: E402


class _Ec:
    """What passes.deon.whole_target / seam_split read of an ExecuteContext."""

    def __init__(self, ctx, scene, graph):
        self.state, self.gl, self.scene, self._g = {}, ctx, scene, graph

    def input(self, name):
        return self._g.texture(name)


def _draw(ctx, graph, prog, fbo, textures: dict, tiles=None) -> None:
    for unit, (name, tex) in enumerate(textures.items()):
        if name in prog:  # a slot BLUR_SOURCES shares is dropped by the compiler
            tex.use(unit)
            prog[name].value = unit
    fbo.use()
    ctx.disable(moderngl.DEPTH_TEST)
    if tiles is not None:
        tiles[0].use(len(textures))
        prog["u_tiles"].value = len(textures)
        if "u_tile" in prog:  # TILED = 1 only
            prog["u_tile"].value = float(tiles[2])
        prog["u_target_size"].value = tuple(float(v) for v in fbo.size)
    graph.gpu.fullscreen_vao(prog).render(vertices=3 if tiles is None else 6 * int(tiles[1]))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--maps", type=int, default=1024)
    ap.add_argument("--size", type=int, default=640)
    ap.add_argument("--repeats", type=int, default=31)
    ap.add_argument("--scan", action="store_true", help="the shared head scan (bench_fidelity.SCAN_VALUES)")
    args = ap.parse_args()
    ctx = headless_context()
    print(f"# the summed step's and the diffuse sum's cuts, draw against draw — {describe(ctx)}; "
          f"load {os.getloadavg()[0]:.1f} at start")
    r = Renderer(ctx)
    s = settings_for("deon", "head", args.size, args.maps, **(SCAN_VALUES if args.scan else {}))
    r.render(s, force=True)
    g = r.graph("deon")
    n = args.maps
    out = ctx.texture((n, n), 4, dtype="f4")
    fbo = ctx.framebuffer([out])
    draws = {}  # label -> list of (program, textures, uniforms, tiles)
    # deon_combine: the declared variant and the one without BLUR_SOURCES, bound as DiffuseSumPass binds them
    refl = g._last_refl["deon_combine"]
    (defines,) = [dict(d) for name, d in refl.programs if name == "deon_combine"]
    blurs = refl.planned.blurs
    ws = np.zeros((8, 3), np.float32)
    for i, gauss in enumerate(s.deon.gaussians):
        ws[i] = gauss.weights
    textures = {f"blur{i}": g.texture(res) for i, (res, _) in enumerate(blurs) if (defines["GAUSSIAN_MASK"] >> i) & 1}
    if "deon_transmitted" in g.resources():
        textures["transmitted"] = g.texture("deon_transmitted")
    for label, d in (("combine, shared fetches once", defines),
                     ("combine, every slot fetched", {k: v for k, v in defines.items() if k != "BLUR_SOURCES"})):
        prog = g.shaders.get("deon_combine", d)
        prog["u_w"].write(ws[:prog["u_w"].array_length].tobytes())
        prog["u_size"].value = (float(n), float(n))
        prog["u_transmitted"].value = int("transmitted" in textures)
        if "u_one" in prog:
            prog["u_one"].value = 1.0
        draws[label] = [(prog, textures, None)]
    # the summed step's seam fill (the irradiance, no border): split | whole, as _execute_gather draws it
    ec = _Ec(ctx, r.scene.gpu, g)
    whole = deon_passes.whole_target(ec, n)
    split = deon_passes.seam_split(ec, n, whole)
    fill_tex = {"source": g.texture("deon_irradiance"), "seam_map": g.texture(seam_resource(n))}
    fill = g.shaders.get("seam_fill", {"TILED": 2})
    plain = g.shaders.get("seam_fill", {"TILED": 2, "NO_SEAM": 1})
    for p in (fill, plain):
        if "u_past_border_dark" in p:
            p["u_past_border_dark"].value = 1
    if split is not None:
        draws["fill, seam + plain tiles"] = [(p, fill_tex, t) for p, t in ((fill, split[0]), (plain, split[1])) if t is not None]
        draws["fill, one draw"] = [(fill, fill_tex, whole)]
    times: dict[str, list[float]] = {k: [] for k in draws}
    result: dict[str, bytes] = {}
    copies = []
    for k in range(args.repeats):
        for label in (list(draws) if k % 2 == 0 else list(draws)[::-1]):
            ctx.finish()
            t0 = time.perf_counter()
            for prog, tex, tiles in draws[label]:
                _draw(ctx, g, prog, fbo, tex, tiles)
            ctx.finish()
            times[label].append((time.perf_counter() - t0) * 1000.0)
            if k == 0:
                result[label] = out.read()
        if k % 5 == 0:
            copies.append(copy_draw_ms(r, n, 3))
    copy = statistics.median(copies)
    print(f"# {'scan' if args.scan else 'head'}, maps {n}^2, {args.repeats} repeats; load {os.getloadavg()[0]:.1f} at the end; "
          f"a plain copy {copy:.2f} ms")
    labels = list(draws)
    for a, b in zip(labels[::2], labels[1::2]):
        ta, tb = statistics.median(times[a]), statistics.median(times[b])
        same = "the same bytes" if result[a] == result[b] else "DIFFERENT BYTES"
        print(f"{a:<32} {ta:8.2f} ms = {ta / copy:5.2f} copies | {b:<28} {tb:8.2f} ms = {tb / copy:5.2f} copies "
              f"({100.0 * (ta / tb - 1.0):+.0f} %; {same})")


if __name__ == "__main__":
    main()
