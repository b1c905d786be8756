"""What splitting a frame into row bands costs (issue 27), side by side in one run: a light move's
frame at the defaults rendered whole (sync timing, no budget), then spread over calls under a
budget with each band drawing only the triangles that reach it (GpuServices.band_vao, the
default), and with each band drawing the whole mesh (as before). Medians of ``--runs``.

    python benchmarks/bench_bands.py [--techniques phong,ssss] [--budget 50] [--runs 3]

The bands are timed with a glFinish around each (``kernel.graph.SAMPLED_SYNC`` off) in the first two
arms, and with sampled sync (a chain of predicted bands timed by the one closing it) in the last.

The defaults a user gets: default settings (1024² maps), a 640×676 view (the viewer's at its default
window)."""
from __future__ import annotations

import argparse
import statistics
import time

from skinviewer.engine.renderer import Renderer
from skinviewer.ground.settings import Settings, with_values
from skinviewer.kernel import gpu as G
from skinviewer.kernel import graph as graph_mod
from skinviewer.kernel.gl import describe, headless_context


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--techniques", default="phong,ssss,penner")
    ap.add_argument("--budget", type=float, default=50.0)
    ap.add_argument("--runs", type=int, default=3)
    a = ap.parse_args()
    ctx = headless_context()
    r = Renderer(ctx)
    culled = G.GpuServices.band_vao

    def whole_mesh(self, prog, scene, lod, *args, **kwargs):  # band_vao's signature, every triangle
        return self.mesh_vao(prog, scene, lod), len(scene.lod_mesh(lod).indices) * 3

    print(f"# bench_bands — {describe(ctx)}; 640x676, default settings, budget {a.budget:g} ms a call, sync timing")
    print(f"{'technique':<10} {'whole':>8} {'bands (culled)':>15} {'×':>5} {'bands (whole mesh)':>19} {'×':>5} "
          f"{'culled, sampled':>16} {'×':>5}")
    for t in a.techniques.split(","):
        s = with_values(Settings(), {"technique": t, "render.width": 640, "render.height": 676})
        r.render(s)
        ms: dict[str, list[float]] = {"whole": [], "culled": [], "mesh": [], "sampled": []}
        for k in range(a.runs):
            for mode in ms:
                G.GpuServices.band_vao = whole_mesh if mode == "mesh" else culled  # type: ignore[method-assign]
                graph_mod.SAMPLED_SYNC = mode == "sampled"  # else a glFinish around every band
                d = [0.3, 0.2 + 0.01 * k + {"whole": 0.0, "culled": 0.003, "mesh": 0.006, "sampled": 0.009}[mode], 1.0]
                s2 = with_values(s, {"lights.0.direction": d})
                t0 = time.perf_counter()
                if mode == "whole":
                    r.render(s2, timing="sync")
                else:
                    while not r.render(s2, budget_ms=a.budget, timing="sync").complete:
                        pass
                ms[mode].append((time.perf_counter() - t0) * 1000.0)
        G.GpuServices.band_vao = culled  # type: ignore[method-assign]
        w, c, m, sm = (statistics.median(ms[k]) for k in ("whole", "culled", "mesh", "sampled"))
        print(f"{t:<10} {w:8.0f} {c:15.0f} {c / w:5.2f} {m:19.0f} {m / w:5.2f} {sm:16.0f} {sm / w:5.2f}", flush=True)
    r.release()
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
