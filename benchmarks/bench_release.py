"""Release -> final and the longest frame of the refinement, A/B in one process (issue 27): what the viewer
does when a light drag stops, without the window (no UI, no presenting), so that the graph's share can be
measured apart from Xvfb and side by side:

- a light drag: ``--drag`` preview frames at the governor's cheapest rung of the technique (ladder's first:
  a ¼ or ½ view with lighter knobs, in the preview's own graph), the light moving a little each frame,
  each frame under the drag's graph budget (72 ms) until complete;
- the release: the user's settings at the drag's last light, frames under a still view's budget
  (0.9 x 100 ms, as ui/frame.py's quiet frames) until complete. Its wall time (sync timing) against the
  same light move rendered alone (no budget), and its longest frame.

Arms (``--arms``), interleaved rep by rep with the light at new positions each time:
``base`` (no pass shared between graphs, bands as counted, the old band_rows), ``share`` (passes whose key
is equal copied between the preview's and the user's graph: RenderGraph.share_passes), ``all`` (and bands
aligned to a pass's draws, ExecuteContext.units, and the per-corner band_rows).

    python benchmarks/bench_release.py [--techniques burley,penner,separable,gosselin] [--reps 3]
"""
from __future__ import annotations

import argparse
import os
import statistics
import sys
import time

import numpy as np

from skinviewer.engine.renderer import Renderer
from skinviewer.ground.settings import Settings, with_values
from skinviewer.kernel import gpu as gpu_mod
from skinviewer.kernel import graph as graph_mod
from skinviewer.kernel.gl import describe, headless_context
from skinviewer.techniques.preview import cheapest
from skinviewer.ui.warm import preview_variant, rung_frame_settings

VIEW = (640, 676)  # the viewer's default view beside the panel
DRAG_BUDGET = 72.0
QUIET_BUDGET = 90.0
NEW_BAND_ROWS = gpu_mod.band_rows


def old_band_rows(scene, lod, space, matrix, rows, cache):
    """kernel/gpu.band_rows before this session: a (T, 3) gather reduced along its rows."""
    key = (id(scene), lod, space, None if matrix is None else np.asarray(matrix, np.float32).tobytes(), rows)
    hit = cache.get(key)
    if hit is not None:
        return hit
    m = scene.lod_mesh(lod)
    if space == "uv":
        y = np.asarray(m.uvs, np.float64)[:, 1] * rows
        ok = np.ones(len(y), bool)
    else:
        p = np.asarray(m.positions, np.float64)
        clip = p @ np.asarray(matrix, np.float64)[:3, :3].T + np.asarray(matrix, np.float64)[:3, 3]
        w = p @ np.asarray(matrix, np.float64)[3, :3] + float(np.asarray(matrix, np.float64)[3, 3])
        ok = w > 1e-6
        y = (clip[:, 1] / np.where(ok, w, 1.0) * 0.5 + 0.5) * rows
    t = np.asarray(m.indices)
    ty = y[t]
    out = np.stack([ty.min(axis=1), ty.max(axis=1)], axis=1)
    out[~ok[t].all(axis=1)] = (-np.inf, np.inf)
    if len(cache) > 16:
        cache.clear()
    cache[key] = out
    return out


def arm(name: str) -> None:
    graph_mod.SHARE_PASSES = name in ("share", "all")
    graph_mod.ALIGN_UNITS = name == "all"
    gpu_mod.band_rows = NEW_BAND_ROWS if name == "all" else old_band_rows


def moved(s: Settings, k: float) -> Settings:
    d = list(s.lights[0].direction)
    return with_values(s, {"lights.0.direction": [d[0] + 0.15 * np.sin(k), d[1] + 0.1 * np.cos(1.3 * k), d[2]]})


def release(r: Renderer, s: Settings, k0: float, drag: int) -> tuple[float, float, int, float]:
    """One light drag and its release: (release -> final ms, longest frame ms, frames, identical)."""
    rung = cheapest(s)
    variant = preview_variant(rung)
    for j in range(drag):
        pv = rung_frame_settings(moved(s, k0 + 0.01 * j), rung, VIEW)
        while not r.render(pv, budget_ms=DRAG_BUDGET, variant=variant, interactive=True).complete:
            pass
    final = moved(s, k0 + 0.01 * (drag - 1))
    t0 = time.perf_counter()
    longest, frames = 0.0, 0
    while True:
        t1 = time.perf_counter()
        rep = r.render(final, budget_ms=QUIET_BUDGET)
        longest = max(longest, (time.perf_counter() - t1) * 1000.0)
        frames += 1
        if rep.complete and not r.graph(s.technique).refining:
            break
    total = (time.perf_counter() - t0) * 1000.0
    img = r.image(final)
    r.render(final, force=True)
    return total, longest, frames, float(np.array_equal(img, r.image(final)))


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--techniques", default="burley,penner,separable,gosselin")
    ap.add_argument("--arms", default="base,share,all")
    ap.add_argument("--reps", type=int, default=3)
    ap.add_argument("--drag", type=int, default=4)
    args = ap.parse_args()
    ctx = headless_context()
    r = Renderer(ctx)
    arms = args.arms.split(",")
    print(f"# bench_release — {describe(ctx)}; view {VIEW[0]}x{VIEW[1]}, default settings (1024² maps); "
          f"drag frames under {DRAG_BUDGET:g} ms, the release's under {QUIET_BUDGET:g} ms (a still view's); "
          f"sync timing; medians of {args.reps} reps, arms interleaved; load {os.getloadavg()[0]:.1f}", flush=True)
    print("| technique | arm | release → final ms | alone ms | × alone | longest frame ms | frames | bit-identical | load |")
    print("| --- | --- | --- | --- | --- | --- | --- | --- | --- |")
    for t in args.techniques.split(","):
        s = with_values(Settings(), {"technique": t, "render.width": VIEW[0], "render.height": VIEW[1]})
        for a in arms:  # every arm's programs compiled and every graph made before timing
            arm(a)
            release(r, s, 0.0, 2)
        res: dict[str, list[tuple[float, ...]]] = {a: [] for a in arms}
        for rep in range(args.reps):
            for a in arms:
                arm(a)
                k = 1.0 + rep * len(arms) + arms.index(a)
                load0 = os.getloadavg()[0]
                total, longest, frames, same = release(r, s, k, args.drag)
                alone = r.render(moved(s, k + 0.5), timing="sync").total_ms  # the same kind of light move, whole
                res[a].append((total, alone, longest, frames, same, 0.5 * (load0 + os.getloadavg()[0])))
        for a in arms:
            rows = res[a]
            med = [statistics.median(x[i] for x in rows) for i in range(4)]
            ratio = statistics.median(x[0] / x[1] for x in rows)
            print(f"| {t} | {a} | {med[0]:,.0f} | {med[1]:,.0f} | {ratio:.2f} | {med[2]:,.0f} (max {max(x[2] for x in rows):,.0f}) "
                  f"| {med[3]:.0f} | {'yes' if all(x[4] for x in rows) else 'NO'} | "
                  f"{min(x[5] for x in rows):.1f}–{max(x[5] for x in rows):.1f} |", flush=True)
    arm("all")
    r.release()
    return 0


if __name__ == "__main__":
    sys.exit(main())
