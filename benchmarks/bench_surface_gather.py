"""What summing the narrow d'Eon blur steps over the surface costs (deon.surface_gather_below_texels,
issue 10 item 1), side by side in one run.

    python benchmarks/bench_surface_gather.py [--sizes 512,1024] [--repeats 5] [--limits 0,3]

The default head and the shared scan (when ../shared is there), the default rig, d'Eon. Forced full
frames, the settings interleaved; medians of sync timing (glFinish + wall clock) of the blur passes
(deon_blur_i), of the gather surface (once per mesh and size) and of the whole frame. The
blurs run once per light change, not per orbit. Accuracy: `benchmarks/bench_fidelity.py --parts seams`
and `skinviewer bench` (the ground truth).
"""
from __future__ import annotations

import argparse
import statistics

from bench_tsm_gather import scenes

from skinviewer.engine.renderer import Renderer
from skinviewer.ground.settings import Settings, with_values
from skinviewer.kernel.gl import describe, headless_context
from skinviewer.passes.deon import GATHER_SURFACE


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--sizes", default="512,1024")
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--limits", default="0,3")
    args = ap.parse_args()
    limits = [float(x) for x in args.limits.split(",")]
    ctx = headless_context()
    r = Renderer(ctx)
    print(f"# narrow blur steps summed over the surface — {describe(ctx)}")
    print(f"# image 320^2, default rig, {args.repeats} repeats; sync timing, medians; "
          "limit = deon.surface_gather_below_texels (0: every step separable)")
    print(f"{'scene':<6} {'map':>5} {'limit':>5} {'gathered':>8} {'blurs ms':>9} {'ratio':>6} {'frame ms':>9} {'ratio':>6} "
          f"{'surface ms (once)':>17}")
    for name, scene in scenes().items():
        for n in (int(x) for x in args.sizes.split(",")):
            base = with_values(Settings(), {**scene, "technique": "deon", "render.width": 320, "render.height": 320,
                                            "render.timing": "sync", "deon.irradiance_size": n})
            variants = {lim: with_values(base, {"deon.surface_gather_below_texels": lim}) for lim in limits}
            for s in variants.values():  # warm-up: compile, scene, allocation, the once-per-mesh maps
                r.render(s, force=True)
            ms: dict[tuple[float, str], list[float]] = {}
            gathered: dict[float, int] = {}
            for _ in range(args.repeats):
                for lim, s in variants.items():
                    rep = r.render(s, force=True)
                    ms.setdefault((lim, "frame"), []).append(rep.total_ms)
                    blur = [p for p in rep.passes if p.name.startswith("deon_blur_") and p.status == "ran"]
                    ms.setdefault((lim, "blur"), []).append(sum(p.ms or 0.0 for p in blur))
                    gathered[lim] = sum(1 for p in blur if GATHER_SURFACE in p.inputs)
                    once = [p.ms or 0.0 for p in rep.passes if p.name == "deon_gather_surface" and p.status == "ran"]
                    ms.setdefault((lim, "once"), []).append(sum(once))
            b0, f0 = statistics.median(ms[(limits[0], "blur")]), statistics.median(ms[(limits[0], "frame")])
            for lim in limits:
                b, f = statistics.median(ms[(lim, "blur")]), statistics.median(ms[(lim, "frame")])
                once = statistics.median(ms[(lim, "once")])
                print(f"{name:<6} {n:>5} {lim:>5.1f} {gathered[lim]:>8} {b:>9.1f} {b / b0:>6.2f} {f:>9.1f} {f / f0:>6.2f} "
                      f"{once:>17.1f}")


if __name__ == "__main__":
    main()
