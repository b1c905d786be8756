"""One shader change, before | after in one process (issue 27: d'Eon's light move against Phong's): a
light move of each technique (a renderer each) with the named program(s) compiled with the extra defines
(B) and as the passes declare them (A), interleaved in each repeat (each side first in every other
repeat). Each draw of the named programs is timed in the process's CPU time (every llvmpipe thread's: far
steadier than wall time on a shared machine) and wall time, glFinish before and after; an unchanged
program beside them as the control (its A and B should agree); and each light-move frame (wall, the
draws fenced), with d'Eon's / Phong's per side. The defaults at the given sizes otherwise.

    python benchmarks/bench_program_ab.py --ab deon_irradiance_texels:PCF_GATHER=0 --ab phong:PCF_GATHER=0
        [--techniques deon,phong] [--control deon_transmitted_texels] [--scene head|scan] [--back-lit]
        [--repeats 9] [--maps 1024] [--size 640]

e.g. the PCF's taps as gathers (lib/lights.glsl PCF_GATHER, on where the GL has textureGather) against
the texel fetches: B = PCF_GATHER=0 for d'Eon's irradiance and Phong's lit pass."""
from __future__ import annotations

import argparse
import collections
import os
import statistics
import sys
import time

sys.path.insert(0, os.path.dirname(__file__))
sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))

import bench_deon_draws as bd  # noqa: E402
from bench_fidelity import SCAN_VALUES  # noqa: E402
from bench_frames import settings_for  # noqa: E402
from bench_pcf_bounds import CPU as DRAWS  # noqa: E402  (program label, CPU s, wall s) of each draw
from bench_pcf_bounds import instrument  # noqa: E402  each draw fenced and timed

from skinviewer.engine.renderer import Renderer  # noqa: E402
from skinviewer.ground.settings import with_values  # noqa: E402
from skinviewer.kernel.gl import describe, headless_context  # noqa: E402

BACK_LIT = {"lights.0.direction": [0.0, 0.2, -1.0]}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--ab", action="append", required=True, help="program:DEFINE=value, the B side's define")
    ap.add_argument("--techniques", default="deon,phong")
    ap.add_argument("--control", default="", help="an unchanged program timed beside (default: none)")
    ap.add_argument("--scene", choices=("head", "scan"), default="head")
    ap.add_argument("--back-lit", action="store_true")
    ap.add_argument("--repeats", type=int, default=9)
    ap.add_argument("--maps", type=int, default=1024)
    ap.add_argument("--size", type=int, default=640)
    args = ap.parse_args()
    variant: dict[str, dict] = {}
    for a in args.ab:
        name, kv = a.split(":", 1)
        variant.setdefault(name, {}).update(bd.parse_sets([kv]))
    techniques = [t for t in args.techniques.split(",") if t]
    ctx = headless_context()
    extra = dict(SCAN_VALUES) if args.scene == "scan" else {}
    if args.back_lit:
        extra.update(BACK_LIT)
    settings = {t: settings_for(t, "head", args.size, args.maps, **extra) for t in techniques}
    print(f"# {', '.join(args.ab)} ({', '.join(techniques)}, {args.scene}{', back-lit' if args.back_lit else ''}, "
          f"{args.size}^2 view, {args.maps}^2 maps) — {describe(ctx)}; load {os.getloadavg()[0]:.1f} at start")
    instrument()
    renderers = {t: Renderer(ctx) for t in techniques}
    for t in techniques:
        renderers[t].render(settings[t], force=True)
    names = list(variant) + ([args.control] if args.control else [])
    cpu: dict[tuple[str, str], list[float]] = collections.defaultdict(list)
    wall: dict[tuple[str, str], list[float]] = collections.defaultdict(list)
    frames: dict[tuple[str, str], list[float]] = collections.defaultdict(list)
    for k in range(args.repeats):
        for side in ("AB" if k % 2 == 0 else "BA"):
            bd.VARIANT.clear()
            if side == "B":
                bd.VARIANT.update(variant)
            for t in techniques:
                s = settings[t]
                d = s.lights[0].direction
                renderers[t].render(s)
                ctx.finish()
                DRAWS.clear()
                t0 = time.perf_counter()
                renderers[t].render(with_values(s, {"lights.0.direction": (d[0] + 0.02 * (k + 1), d[1], d[2])}))
                ctx.finish()
                frames[(side, t)].append((time.perf_counter() - t0) * 1000.0)
                for n in names:
                    mine = [(c, w) for p, c, w in DRAWS if p.split("[")[0] == n]
                    if mine:
                        cpu[(side, n)].append(sum(c for c, _ in mine) * 1000.0)
                        wall[(side, n)].append(sum(w for _, w in mine) * 1000.0)
    bd.VARIANT.clear()
    print(f"# load {os.getloadavg()[0]:.1f} at the end; medians over {args.repeats} light moves; "
          f"A = as declared, B = with {variant}")
    print(f"{'program':<34} {'A CPU ms':>9} {'B CPU ms':>9} {'A / B':>6} {'A wall':>8} {'B wall':>8} {'A / B':>6}")
    for n in names:
        if not cpu[("A", n)]:
            print(f"{n:<34} (not drawn in a light move)")
            continue
        ca, cb = statistics.median(cpu[("A", n)]), statistics.median(cpu[("B", n)])
        wa, wb = statistics.median(wall[("A", n)]), statistics.median(wall[("B", n)])
        tag = " (control)" if n == args.control else ""
        print(f"{n + tag:<34} {ca:9.1f} {cb:9.1f} {ca / max(cb, 1e-9):6.3f} {wa:8.1f} {wb:8.1f} {wa / max(wb, 1e-9):6.3f}")
    med = {key: statistics.median(v) for key, v in frames.items()}
    for t in techniques:
        print(f"light move {t:<23} {med[('A', t)]:9.1f} {med[('B', t)]:9.1f} {med[('A', t)] / med[('B', t)]:6.3f}  (wall ms, draws fenced)")
    if "deon" in techniques and "phong" in techniques:
        print(f"d'Eon / Phong: A {med[('A', 'deon')] / med[('A', 'phong')]:.2f} x, "
              f"B {med[('B', 'deon')] / med[('B', 'phong')]:.2f} x")


if __name__ == "__main__":
    main()
