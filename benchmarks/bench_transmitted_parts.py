"""Where d'Eon's transmitted light spends its time (issue 27): the deon_transmitted draw (one fragment per
texel of its 512^2 map at the defaults, lib/tsm_transmit.glsl) timed with parts of the shader compiled out
(a measurement, not output: lib/tsm_transmit.glsl TSM_PROBE 1 = no light-space gather, 2 = no 3x3 tap terms,
4 = the setup only (the skip's test and the surface read), 3 = neither), beside the draw as shipped (A) and
any --variant DEFINE=value, interleaved in every repeat, for each scene (the head; the shared scan) and light
(the defaults' key in front; the key behind the head). Sync timing (a glFinish either side of the draw),
medians, in plain copies (shaders/copy.frag, RGBA32F) of the 1024^2 map; and, from a render with
TSM_PROBE = 8, per island texel: how many gathered Gaussians pass their own skip and how many of those add
a non-zero term; with --work, each side's work (texels past the skips, gathered Gaussians and live taps a
texel and a 4x4 block), which the load does not move.

    python benchmarks/bench_transmitted_parts.py [--maps 1024] [--size 640] [--repeats 3] [--scenes head,scan]
        [--lights front,back] [--probes 1,2,4,3] [--variant TSM_TAPS_NARROW=0,TSM_MAX_CHANNELS=1 ...] [--no-counts] [--work]
"""
from __future__ import annotations

import argparse
import os
import statistics
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(__file__))
sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))

import bench_deon_draws as draws  # noqa: E402
from bench_frames import copy_draw_ms, settings_for  # noqa: E402
from bench_tsm_gather import scenes as shared_scenes  # noqa: E402
from bench_tsm_skip import LIGHTS  # noqa: E402

import skinviewer.passes.deon as deon_passes  # noqa: E402
from skinviewer.engine.renderer import Renderer  # noqa: E402
from skinviewer.ground.settings import with_values  # noqa: E402
from skinviewer.kernel.gl import describe, headless_context  # noqa: E402

PROGRAM = "deon_transmitted_texels"


def moved(s, k: int):
    d = s.lights[0].direction
    return with_values(s, {"lights.0.direction": (d[0] + 0.02 * (k + 1), d[1], d[2])})


def transmitted_ms(r: Renderer, s, s2, defines: dict) -> float:
    """The transmitted draw's ms in a light move s -> s2 with ``defines`` added to its program."""
    draws.VARIANT.clear()
    r.render(s)
    draws.VARIANT[PROGRAM] = defines
    draws.LOG.clear()
    r.render(s2)
    draws.VARIANT.clear()
    return sum(ms for p, prog, _t, ms in draws.LOG if p == "deon_transmitted" and prog.startswith(PROGRAM))


def work(r: Renderer, s, s2, defines: dict) -> tuple[float, float, float, float, float]:
    """The work ``defines``' variant does, from a TSM_PROBE = 8 render (deterministic, unlike the ms):
    (share of island texels past the whole skip and the lit early return, gathered Gaussians past their own
    skip per island texel, share with live tap terms; the last two per 4x4 block of texels as a SIMD
    rasterizer runs them: the block pays for its busiest texel)."""
    draws.VARIANT.clear()
    r.render(s)
    draws.VARIANT[PROGRAM] = {**defines, "TSM_PROBE": 8}
    r.render(s2)
    draws.VARIANT.clear()
    g = r.graph("deon")
    t = g.read(deon_passes.TRANSMITTED)[..., :3].astype(np.float64)
    n = t.shape[0]
    cov = g.read(f"texel_surface_{n}_p")[..., 3] != 0
    r.render(s, force=True)  # the probe's texture is not the frame's
    reached = cov & (t[..., 2] >= 1.0)
    gath = np.where(reached, t[..., 0], 0.0)
    taps = np.where(reached & (t[..., 2] == 2.0), 1.0, 0.0)
    tot = max(int(cov.sum()), 1)
    b = n // 4
    blk = lambda a: a[:b * 4, :b * 4].reshape(b, 4, b, 4).max(axis=(1, 3))  # noqa: E731
    cb = blk(cov.astype(np.float64)) > 0
    nb = max(int(cb.sum()), 1)
    return (reached.sum() / tot, gath.sum() / tot, taps.sum() / tot, blk(gath)[cb].sum() / nb, blk(taps)[cb].sum() / nb)


def counts(r: Renderer, s, s2) -> str:
    draws.VARIANT.clear()
    r.render(s)
    draws.VARIANT[PROGRAM] = {"TSM_PROBE": 8}
    r.render(s2)
    draws.VARIANT.clear()
    g = r.graph("deon")
    t = g.read(deon_passes.TRANSMITTED)[..., :3]
    n = t.shape[0]
    cov = g.read(f"texel_surface_{n}_p")[..., 3] != 0
    reached = cov & (t[..., 2] >= 1.0)
    entered, nonzero = t[..., 0][reached], t[..., 1][reached]
    tot = max(int(cov.sum()), 1)
    hist = " ".join(f"{k}:{100 * np.mean(entered == k) * reached.sum() / tot:.0f}%" for k in range(4))
    hz = " ".join(f"{k}:{100 * np.mean(nonzero == k) * reached.sum() / tot:.0f}%" for k in range(4))
    r.render(s, force=True)  # the probe's texture is not the frame's
    return (f"reach the gather {100 * reached.sum() / tot:.0f} % of {tot} island texels; gathered Gaussians past "
            f"their skip {hist}; non-zero {hz}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--maps", type=int, default=1024)
    ap.add_argument("--size", type=int, default=640)
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--scenes", default="head,scan")
    ap.add_argument("--lights", default="front,back")
    ap.add_argument("--probes", default="1,2,4,3")
    ap.add_argument("--variant", action="append", default=[])
    ap.add_argument("--no-counts", action="store_true")
    ap.add_argument("--work", action="store_true", help="each side's work from a TSM_PROBE = 8 render (deterministic)")
    args = ap.parse_args()
    ctx = headless_context()
    print(f"# deon_transmitted by parts — {describe(ctx)}; load {os.getloadavg()[0]:.1f} at start")
    draws.instrument()
    sides = {"A": {}}
    for p in [int(x) for x in args.probes.split(",") if x]:
        sides[f"PROBE={p}"] = {"TSM_PROBE": p}
    for v in args.variant:  # DEFINE=value[,DEFINE=value...]
        sides[v] = draws.parse_sets(v.split(","))
    scenes = {k: v for k, v in shared_scenes().items() if k in args.scenes.split(",")}
    print("| scene | light | " + " | ".join(sides) + " | copy ms | load |")
    print("| --- | --- | " + " | ".join("---" for _ in sides) + " | --- | --- |")
    for scene_name, scene in scenes.items():
        for light in args.lights.split(","):
            extra = {k: list(v) for k, v in LIGHTS[light].items()}
            s = with_values(settings_for("deon", "head", args.size, args.maps), {**scene, **extra})
            r = Renderer(ctx)
            try:
                r.render(s, force=True)
                note = "" if args.no_counts else counts(r, s, moved(s, 0))
                if args.work:
                    for name, d in sides.items():
                        if "TSM_PROBE" in d:
                            continue
                        w = work(r, s, moved(s, 0), d)
                        print(f"#   work {scene_name} {light} {name}: past the skips {100 * w[0]:.1f} % of island "
                              f"texels; gathered Gaussians a texel {w[1]:.3f} (a 4x4 block {w[3]:.3f}); live taps "
                              f"{100 * w[2]:.1f} % (blocks {100 * w[4]:.1f} %)", flush=True)
                per = {k: [] for k in sides}
                cp = []
                names = list(sides)
                for k in range(args.repeats):
                    order = names[k % len(names):] + names[:k % len(names)]
                    for name in order:
                        per[name].append(transmitted_ms(r, s, moved(s, k), sides[name]))
                    cp.append(copy_draw_ms(r, args.maps, 3))
            finally:
                r.release()
            c = statistics.median(cp)
            cells = " | ".join(f"{statistics.median(v):.1f} ({statistics.median(v) / c:.1f})" for v in per.values())
            print(f"| {scene_name} | {light} | {cells} | {c:.2f} | {os.getloadavg()[0]:.1f} |", flush=True)
            if note:
                print(f"#   {scene_name} {light}: {note}", flush=True)


if __name__ == "__main__":
    main()
