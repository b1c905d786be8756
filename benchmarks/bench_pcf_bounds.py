"""The PCF's exact early-out (issue 27; lib/lights.glsl SHADOW_BOUNDS, notes/deon_light_move.md section 13),
before | after in one process: a light move's draws of one lit program, compiled without the early-out (B:
SHADOW_BOUNDS=0) and with it (A), interleaved in each repeat (each side first in every other repeat), timed
in the process's CPU time (every llvmpipe thread's: far steadier than wall time on a loaded machine) and wall
time, glFinish before and after each draw; the shadow_bounds pass beside them. Runs with the bounds on
(passes.common.PCF_BOUNDS) whatever SKINVIEWER_PCF_BOUNDS says.

    python benchmarks/bench_pcf_bounds.py [--program deon_irradiance_texels] [--technique deon]
        [--scene head|scan] [--back-lit] [--repeats 5] [--maps 1024] [--size 640]

and the share of lookups the bounds decide (--share: d'Eon's per-texel visibility, marked)."""
from __future__ import annotations

import argparse
import os
import statistics
import sys
import time

sys.path.insert(0, os.path.dirname(__file__))
sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))

import bench_deon_draws as bd  # noqa: E402
from bench_fidelity import SCAN_VALUES  # noqa: E402
from bench_frames import settings_for  # noqa: E402

import skinviewer.passes.common as common  # noqa: E402
from skinviewer.engine.renderer import Renderer  # noqa: E402
from skinviewer.ground.settings import with_values  # noqa: E402
from skinviewer.kernel import execute  # noqa: E402
from skinviewer.kernel.gl import describe, headless_context  # noqa: E402

BACK_LIT = {"lights.0.direction": [0.0, 0.2, -1.0]}
CPU: list[tuple[str, float, float]] = []


def instrument() -> None:
    bd.instrument()  # names the programs and applies bd.VARIANT (the B side's defines)
    ec_cls = execute.ExecuteContext
    for meth in ("draw_fullscreen", "draw_mesh"):
        orig = getattr(ec_cls, meth)

        def timed(self, prog, *a, _orig=orig, **k):
            self.gl.finish()
            c0, t0 = time.process_time(), time.perf_counter()
            _orig(self, prog, *a, **k)
            self.gl.finish()
            CPU.append((bd.NAMES.get(id(prog), "?"), time.process_time() - c0, time.perf_counter() - t0))

        setattr(ec_cls, meth, timed)


def share(ctx, s) -> None:
    """Of d'Eon's lookups (texels with N.L > 0): decided lit, decided shadowed, read (their taps)."""
    import numpy as np
    common.PCF_BOUNDS_MARK = True
    r = Renderer(ctx)
    try:
        r.render(with_values(s, {"deon.specular_shadows": "texture"}))
        m = r.graph("deon").read("deon_visibility")[..., 0].astype(np.float32)
    finally:
        r.release()
        common.PCF_BOUNDS_MARK = False
    lit, shadowed, read = (m == -1).sum(), (m == -2).sum(), (m > 0).sum()
    total = lit + shadowed + read
    print(f"# lookups decided lit {lit} ({lit / total:.0%}), decided shadowed {shadowed} ({shadowed / total:.0%}), "
          f"read (partly lit or undecided) {read} ({read / total:.0%}; texels whose taps are all shadowed but "
          "undecided are not counted)")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--program", default="deon_irradiance_texels")
    ap.add_argument("--technique", default="deon")
    ap.add_argument("--scene", choices=("head", "scan"), default="head")
    ap.add_argument("--back-lit", action="store_true")
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--maps", type=int, default=1024)
    ap.add_argument("--size", type=int, default=640)
    ap.add_argument("--share", action="store_true")
    args = ap.parse_args()
    common.PCF_BOUNDS = True
    ctx = headless_context()
    extra = dict(SCAN_VALUES) if args.scene == "scan" else {}
    if args.back_lit:
        extra.update(BACK_LIT)
    s = settings_for(args.technique, "head", args.size, args.maps, **extra)
    print(f"# {args.program} ({args.technique}, {args.scene}{', back-lit' if args.back_lit else ''}, "
          f"{args.size}^2 view, {args.maps}^2 maps) — {describe(ctx)}; load {os.getloadavg()[0]:.1f} at start")
    if args.share and args.technique == "deon":
        share(ctx, s)
    instrument()
    r = Renderer(ctx)
    r.render(s, force=True)
    sides = {"B (no early-out)": {"SHADOW_BOUNDS": 0}, "A (early-out)": {}}
    cpu: dict[str, list[float]] = {k: [] for k in sides}
    wall: dict[str, list[float]] = {k: [] for k in sides}
    bounds: list[float] = []
    d = s.lights[0].direction
    for k in range(args.repeats):
        for side in (list(sides) if k % 2 == 0 else list(sides)[::-1]):
            bd.VARIANT.clear()
            bd.VARIANT[args.program] = sides[side]
            r.render(s)
            CPU.clear()
            r.render(with_values(s, {"lights.0.direction": (d[0] + 0.02 * (k + 1), d[1], d[2])}))
            cpu[side].append(sum(c for n, c, _ in CPU if n.startswith(args.program)) * 1000.0)
            wall[side].append(sum(w for n, _, w in CPU if n.startswith(args.program)) * 1000.0)
            bounds.append(sum(c for n, c, _ in CPU if n.startswith("shadow_bounds")) * 1000.0)
    print(f"# load {os.getloadavg()[0]:.1f} at the end; medians over {args.repeats} light moves")
    for side in sides:
        print(f"{side:18s} {args.program}: CPU {statistics.median(cpu[side]):7.1f} ms  wall {statistics.median(wall[side]):7.1f} ms"
              f"  (CPU {[round(x) for x in cpu[side]]})")
    print(f"{'':18s} shadow_bounds: CPU {statistics.median(bounds):7.1f} ms (A's cost; B reads none but builds it too)")


if __name__ == "__main__":
    main()
