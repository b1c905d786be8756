"""Where one separable d'Eon blur direction's time goes (issue 27, "Also asked": one direction <= 2 plain
copies), at the defaults (head, 640^2 view, 1024^2 maps: blur_4 and blur_5, one sub-step each, at half size).

    python benchmarks/bench_blur_direction.py [--maps 1024] [--repeats 5] [--paired 5]

Per separable blur pass of a light-move frame (medians over --repeats):
* the calls its execute makes (draws, texture binds, uniform sets) and its Python time: the execute's wall
  time minus the time spent inside the draw calls (unfenced frames, as the viewer runs them);
* its pass time (the graph's sync timing: glFinish before and after) and, in fenced frames (glFinish around
  each draw: llvmpipe's timer queries are not trustworthy), each kind of draw's time and the share of the
  map its tile list covers; all in plain copies (shaders/copy.frag, RGBA32F) of the full and the half size.

--paired K: the alternatives to the draws, measured in the frame at the moment of the draw on the same
inputs (the machine is shared: frames minutes apart see different load, back-to-back draws see the same):
at each tiled seam fill over the whole target, the fill as one seam-fill draw (A) against the split the
pass draws (B: seam rectangles + plain NO_SEAM rectangles, passes.deon.seam_split), alternately K times
each, fenced; both write the same values into the same target, so the frame goes on unchanged.
"""
from __future__ import annotations

import argparse
import collections
import os
import statistics
import sys
import time

import numpy as np

sys.path.insert(0, os.path.dirname(__file__))
sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))

from bench_frames import copy_draw_ms, settings_for  # noqa: E402

import skinviewer.passes.deon as deon_passes  # noqa: E402
from skinviewer.engine.renderer import Renderer  # noqa: E402
from skinviewer.ground.settings import with_values  # noqa: E402
from skinviewer.kernel import execute  # noqa: E402
from skinviewer.kernel.gl import describe, headless_context  # noqa: E402

PASSES = ("deon_blur_4", "deon_blur_5")
EC = execute.ExecuteContext
STATE: dict = {"pass": None, "fence": False, "paired": 0}
CALLS: collections.Counter = collections.Counter()  # (pass, call) -> count in this frame
IN_DRAW: collections.Counter = collections.Counter()  # pass -> ms inside draw calls
DRAWS: list[tuple[str, str, float, float]] = []  # (pass, kind, ms, share of the target)
PAIRS: dict[tuple[str, str], dict[str, list[float]]] = collections.defaultdict(lambda: {"A": [], "B": []})
ORIG_DRAW = EC.draw_fullscreen  # the draw itself, before instrument() wraps it


def kind(defines: dict[str, str]) -> str:
    """A blur pass's draw kind from its program's defines."""
    if "DILATE" in defines or "DOWN" in defines:
        return "fill" + (" down" if "DOWN" in defines else "") + (" plain" if "NO_SEAM" in defines else " seam")
    return "blur " + ("zone-free" if "NO_ZONE_CHECKS" in defines else "checked")


def share(tiles, size: tuple[int, int]) -> float:
    """The share of a size target a TILED = 2 list covers (1 without a list)."""
    if tiles is None:
        return 1.0
    b = np.frombuffer(tiles[0].read(), np.float32).reshape(int(tiles[1]), tiles[0].components)
    area = (b[:, 2] * b[:, 3]).sum() if tiles[0].components == 4 else len(b) * tiles[2] ** 2
    return float(min(area / (size[0] * size[1]), 1.0))


def instrument() -> None:
    """Count the blur passes' calls, time their draw calls, and (--paired) time the fill alternatives."""
    for name in ("bind", "set"):
        orig = getattr(EC, name)

        def counted(self, *a, _orig=orig, _name=name, **k):
            if self.pass_.name in PASSES:
                CALLS[(self.pass_.name, _name)] += 1
            return _orig(self, *a, **k)
        setattr(EC, name, counted)
    draw = EC.draw_fullscreen

    def timed(self, prog, *targets, tiles=None, **kw):
        name = self.pass_.name
        if name not in PASSES:
            return draw(self, prog, *targets, tiles=tiles, **kw)
        CALLS[(name, "draw")] += 1
        d = self.graph.shaders.program_defines(prog)
        fbo = self._target(targets)
        if STATE["paired"] and tiles is not None and "NO_SEAM" not in d and ("DILATE" in d or "DOWN" in d):
            paired_fill(self, prog, targets, tiles, d, kw)
        if STATE["fence"]:
            self.gl.finish()
        t0 = time.perf_counter()
        draw(self, prog, *targets, tiles=tiles, **kw)
        if STATE["fence"]:
            self.gl.finish()
        ms = (time.perf_counter() - t0) * 1000.0
        IN_DRAW[name] += ms
        if STATE["fence"]:
            DRAWS.append((name, kind(d), ms, share(tiles, fbo.size)))
    EC.draw_fullscreen = timed
    run = deon_passes.GaussianBlurPass.execute

    def execute_timed(self, ec):
        t0 = time.perf_counter()
        try:
            return run(self, ec)
        finally:
            if self.name in PASSES:
                CALLS[(self.name, "execute ms")] += (time.perf_counter() - t0) * 1000.0
    deon_passes.GaussianBlurPass.execute = execute_timed


def paired_fill(ec, prog, targets, tiles, defines: dict[str, str], kw: dict) -> None:
    """At the seam part of a fill whose tiles are the whole target (work_tiles' one tile): one seam-fill draw
    over the whole target (A) against the pass's split, seam_split's seam + plain rectangles (B)."""
    n = ec._target(targets).size[0]
    objs = ec.state.get("gl_objects", {})
    whole = [v for key, v in objs.items() if key[0] == "work_tiles" and key[2] == n and key[4] and v is not None
             and v[2] >= n]
    split = deon_passes.seam_split(ec, n, whole[0]) if whole else None
    if split is None or split[0] is not tiles or split[1] is None:
        return  # not a split whole-target fill
    tiles = whole[0]
    plain = ec.program("seam_fill", **{k: int(v) for k, v in defines.items() if k != "MAX_GAUSSIANS"}, NO_SEAM=1)
    for sampler, (_unit, tex) in ec._bound.get(id(prog), {}).items():
        if sampler != "u_tiles":
            ec.bind(plain, sampler, tex)
    ec.set(plain, "u_past_border_dark", bool(prog["u_past_border_dark"].value) if "u_past_border_dark" in prog
           else True, optional=True)
    draw = ORIG_DRAW
    key = (ec.pass_.name, kind(defines).replace(" seam", ""))
    for k in range(STATE["paired"]):
        for side in ("A", "B") if k % 2 == 0 else ("B", "A"):
            ec.gl.finish()
            t0 = time.perf_counter()
            if side == "A":
                draw(ec, prog, *targets, tiles=tiles, **kw)
            else:
                draw(ec, prog, *targets, tiles=split[0], **kw)  # what the pass draws
                draw(ec, plain, *targets, tiles=split[1], **kw)
            ec.gl.finish()
            PAIRS[key][side].append((time.perf_counter() - t0) * 1000.0)


def frame(r: Renderer, s, k: int):
    """A light-move frame (the base frame first, untimed and uncounted): its report."""
    d = s.lights[0].direction
    r.render(s)
    r.ctx.finish()
    CALLS.clear()
    IN_DRAW.clear()
    DRAWS.clear()
    rep = r.render(with_values(s, {"lights.0.direction": (d[0] + 0.02 * (k + 1), d[1], d[2])}))
    r.ctx.finish()
    return rep


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--maps", type=int, default=1024)
    ap.add_argument("--size", type=int, default=640)
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--paired", type=int, default=0, help="K: the whole-target fills as one draw vs split, K times each")
    args = ap.parse_args()
    ctx = headless_context()
    print(f"# one blur direction, where the time goes — {describe(ctx)}; load {os.getloadavg()[0]:.1f} at start")
    instrument()
    r = Renderer(ctx)
    s = settings_for("deon", "head", args.size, args.maps)
    r.render(s, force=True)
    calls: dict = collections.defaultdict(list)
    python: dict = collections.defaultdict(list)
    pass_ms: dict = collections.defaultdict(list)
    draws: dict = collections.defaultdict(list)
    shares: dict = {}
    dirs: dict = {}
    copies, halves = [], []
    for k in range(args.repeats):
        STATE["fence"], STATE["paired"] = False, 0
        rep = frame(r, s, k)  # unfenced: the calls, the Python time, the pass time
        for p in rep.passes:
            if p.name in PASSES and p.status == "ran":
                pass_ms[p.name].append(p.ms)
                dirs[p.name] = p.figures.get("directions", 2)
                python[p.name].append(CALLS[(p.name, "execute ms")] - IN_DRAW[p.name])
                for c in ("draw", "bind", "set"):
                    calls[(p.name, c)].append(CALLS[(p.name, c)])
        STATE["fence"], STATE["paired"] = True, args.paired
        frame(r, s, k)  # fenced: each draw's time (and --paired's alternatives)
        per = collections.defaultdict(float)
        for name, kd, ms, sh in DRAWS:
            per[(name, kd)] += ms
            shares[(name, kd)] = sh
        for key, ms in per.items():
            draws[key].append(ms)
        copies.append(copy_draw_ms(r, args.maps, 3))
        halves.append(copy_draw_ms(r, args.maps // 2, 3))
    c, h = statistics.median(copies), statistics.median(halves)
    med = statistics.median
    print(f"# head, {args.size}^2 view, {args.maps}^2 maps, {args.repeats} repeats, medians; load {os.getloadavg()[0]:.1f}"
          f" at the end; a plain copy {c:.2f} ms ({args.maps}^2), {h:.2f} ms ({args.maps // 2}^2)")
    for name in PASSES:
        if name not in pass_ms:
            continue
        nd = dirs[name]
        print(f"{name}: {nd} directions; per frame {med(calls[(name, 'draw')]):.0f} draws, "
              f"{med(calls[(name, 'bind')]):.0f} binds, {med(calls[(name, 'set')]):.0f} uniform sets; Python "
              f"{med(python[name]):.2f} ms; pass {med(pass_ms[name]):.2f} ms = per direction "
              f"{med(pass_ms[name]) / nd / c:.2f} copies ({med(pass_ms[name]) / nd / h:.2f} half-size copies)")
        total = 0.0
        for (pn, kd), v in sorted(draws.items()):
            if pn != name:
                continue
            total += med(v)
            print(f"    {kd:<20} {med(v) / nd:7.2f} ms a direction = {med(v) / nd / h:5.2f} half-size copies, "
                  f"over {100 * shares[(pn, kd)]:3.0f} % of the map (the frame's draws / directions)")
        print(f"    {'fenced draws':<20} {total / nd:7.2f} ms a direction = {total / nd / h:5.2f} half-size copies")
    for (name, kd), v in sorted(PAIRS.items()):
        a, b = med(v["A"]), med(v["B"])
        print(f"paired {name} {kd}: one draw {a:.2f} ms ({a / h:.2f} half-size copies), split {b:.2f} ms "
              f"({b / h:.2f}); one draw {100 * (a / b - 1):+.1f} %, n = {len(v['A'])}")


if __name__ == "__main__":
    main()
