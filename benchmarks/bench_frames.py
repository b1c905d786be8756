"""Frame time of each technique relative to Phong, full frame vs camera-only frame, measured side by
side in one run (synchronous per-pass timing: glFinish + wall clock, right on llvmpipe).

    python benchmarks/bench_frames.py [--scene head] [--size 256] [--maps 512] [--repeats 5]

A "full frame" re-runs every pass (forced); a "camera-only frame" changes the yaw, so the graph
re-runs only view-dependent passes. Figures are medians over --repeats, interleaved across
techniques so machine noise hits all of them alike. Also printed: GPU texture memory each technique
holds (from its graph's texture specs).
"""
from __future__ import annotations

import argparse
import statistics
import time

from skinviewer import techniques
from skinviewer.core.gl import describe, headless_context
from skinviewer.core.renderer import Renderer
from skinviewer.core.settings import Settings, with_values
from skinviewer.scene.scenes import scene_overrides


def settings_for(tech: str, scene: str, size: int, maps: int) -> Settings:
    return with_values(Settings(), {"scene.name": scene, **scene_overrides(scene), "technique": tech,
                                    "render.width": size, "render.height": size, "render.timing": "sync",
                                    "shadow.map_size": maps, "gosselin.light_map_size": maps,
                                    "deon.irradiance_size": maps, "deon.tsm_size": maps})


def wall_ms(fn) -> float:
    t0 = time.perf_counter()
    fn()
    return (time.perf_counter() - t0) * 1000.0


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--scene", default="head")
    ap.add_argument("--size", type=int, default=256)
    ap.add_argument("--maps", type=int, default=512, help="shadow / light / irradiance map size")
    ap.add_argument("--repeats", type=int, default=5)
    args = ap.parse_args()

    ctx = headless_context()
    r = Renderer(ctx)
    names = techniques.names()
    base = {t: settings_for(t, args.scene, args.size, args.maps) for t in names}
    full: dict[str, list[float]] = {t: [] for t in names}
    cam: dict[str, list[float]] = {t: [] for t in names}
    passes_full: dict[str, float] = {}
    ran_cam: dict[str, list[str]] = {}
    for t in names:  # warm-up: compile shaders, build scene, first allocation
        r.render(base[t], force=True)
    for k in range(args.repeats):
        for t in names:
            s = base[t]
            full[t].append(wall_ms(lambda: (r.render(s, force=True), ctx.finish())))
            passes_full[t] = r.graph(t).last_report.total_ms
            s2 = with_values(s, {"camera.yaw": s.camera.yaw + 5.0 * (k + 1)})
            rep = None

            def cam_frame():
                nonlocal rep
                rep = r.render(s2)
                ctx.finish()
            cam[t].append(wall_ms(cam_frame))
            ran_cam[t] = rep.ran
            r.render(s)  # back to the base view (not timed)

    print(f"# skinviewer frame times — {describe(ctx)}")
    print(f"# scene={args.scene} image={args.size}x{args.size} maps={args.maps}^2 repeats={args.repeats}; "
          f"timing mode: sync (glFinish + wall clock)")
    ref = statistics.median(full["phong"])
    hdr = f"{'technique':<10} {'full ms':>9} {'x phong':>8} {'camera-only ms':>15} {'x phong':>8} {'cam/full':>9} {'tex MiB':>8}  camera-only re-ran"
    print(hdr)
    print("-" * len(hdr))
    for t in names:
        f, c = statistics.median(full[t]), statistics.median(cam[t])
        mib = sum(spec.nbytes for spec in r.graph(t).resources().values()) / 2**20
        print(f"{t:<10} {f:9.1f} {f / ref:8.2f} {c:15.1f} {c / ref:8.2f} {c / f:9.2f} {mib:8.1f}  {', '.join(ran_cam[t])}")
    print()
    for t in names:
        print(f"## {t}: last full frame, per pass")
        print(r.render(base[t], force=True).table())
    r.release()
    ctx.release()


if __name__ == "__main__":
    main()
