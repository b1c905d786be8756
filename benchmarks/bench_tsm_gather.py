"""What the TSM's light-space gather costs (deon.tsm_gather, issue 10 item 4), side by side in one run.

    python benchmarks/bench_tsm_gather.py [--size 512] [--repeats 5] [--samples 0,8,16,32]

The default head and the shared scan (when ../shared is there), lit from behind the ear by one
directional light (the view of notes/fidelity.md), d'Eon at the default maps (irradiance and TSM
1024^2, the transmitted light at 512^2). Forced full frames, the sample counts interleaved; medians
of sync timing (glFinish + wall clock) of deon_transmitted (where the gather runs: once per light
change, not per orbit) and of the whole frame. Accuracy is `skinviewer bench`'s (the ground truth).
"""
from __future__ import annotations

import argparse
import os
import statistics
from pathlib import Path

from skinviewer.engine.renderer import Renderer
from skinviewer.ground.settings import Settings, with_values
from skinviewer.kernel.gl import describe, headless_context

# ../shared beside the checkout, or SKINVIEWER_SHARED (as tests/conftest.py)
SHARED = Path(os.environ.get("SKINVIEWER_SHARED") or Path(__file__).resolve().parents[2] / "shared")
SCAN = SHARED / "assets" / "lee-perry-smith" / "LeePerrySmith.glb"
LIGHT = [{"kind": "directional", "direction": [0.3, 0.25, -1.0], "intensity": 3.0, "cast_shadow": True}]


def scenes() -> dict[str, dict]:
    out = {"head": {"scene.name": "head"}}
    if SCAN.is_file():
        out["scan"] = {"scene.mesh": str(SCAN), "scene.mm_per_unit": 48.0}
    else:
        print(f"# no scan at {SCAN}: the head only")
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--size", type=int, default=512)
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--samples", default="0,8,16,32")
    args = ap.parse_args()
    counts = [int(x) for x in args.samples.split(",")]
    ctx = headless_context()
    r = Renderer(ctx)
    print(f"# TSM light-space gather — {describe(ctx)}")
    print(f"# image {args.size}^2, default maps, light behind the ear, {args.repeats} repeats; sync timing, medians")
    print(f"{'scene':<6} {'samples':>7} {'transmitted ms':>15} {'ratio':>6} {'frame ms':>9} {'ratio':>6}")
    for name, scene in scenes().items():
        base = with_values(Settings(), {**scene, "technique": "deon", "lights": LIGHT, "camera.yaw": 60.0,
                                        "camera.pitch": 5.0, "render.width": args.size, "render.height": args.size,
                                        "render.timing": "sync", "deon.tsm_auto": False})
        variants = {n: with_values(base, {"deon.tsm_gather": n}) for n in counts}
        for s in variants.values():  # warm-up: compile, scene, allocation
            r.render(s, force=True)
        ms: dict[tuple[int, str], list[float]] = {}
        for _ in range(args.repeats):
            for n, s in variants.items():
                rep = r.render(s, force=True)
                ms.setdefault((n, "frame"), []).append(rep.total_ms)
                for p in rep.passes:
                    if p.name == "deon_transmitted" and p.status == "ran" and p.ms is not None:
                        ms.setdefault((n, "t"), []).append(p.ms)
        t0, f0 = statistics.median(ms[(counts[0], "t")]), statistics.median(ms[(counts[0], "frame")])
        for n in counts:
            t, f = statistics.median(ms[(n, "t")]), statistics.median(ms[(n, "frame")])
            print(f"{name:<6} {n:>7} {t:>15.1f} {t / t0:>6.2f} {f:>9.1f} {f / f0:>6.2f}")


if __name__ == "__main__":
    main()
