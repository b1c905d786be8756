"""d'Eon's transmitted light with and without the skip of the texels no TSM read can reach (issue 27;
lib/tsm_transmit.glsl TSM_SKIP, passes.deon.TsmMaxPass), side by side in one process: for each scene
(the head; the shared scan when it is there) and light (the defaults' key in front; the key moved behind
the head), a light-move frame with the skip (A) and without it (B, passes.deon.TSM_SKIP off, its own
renderer), interleaved in every repeat with Phong's light move, at the defaults (640^2 view, 1024^2
maps). Sync timing (render.timing = sync: each pass fenced), medians; the transmitted pass and the TSM
max pass in plain copies (shaders/copy.frag, RGBA32F) of the map size; the share of the transmitted
map's island texels the skip returns before its loops (a -1 marker, passes.deon.TSM_SKIP_MARK).

    python benchmarks/bench_tsm_skip.py [--maps 1024] [--size 640] [--repeats 3] [--scenes head,scan]
        [--lights front,back]
"""
from __future__ import annotations

import argparse
import os
import statistics
import sys

sys.path.insert(0, os.path.dirname(__file__))
sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))

from bench_blur_floor import light_frame  # noqa: E402
from bench_frames import copy_draw_ms, settings_for  # noqa: E402
from bench_tsm_gather import scenes as shared_scenes  # noqa: E402

import skinviewer.passes.deon as deon_passes  # noqa: E402
from skinviewer.engine.renderer import Renderer  # noqa: E402
from skinviewer.ground.settings import with_values  # noqa: E402
from skinviewer.kernel.gl import describe, headless_context  # noqa: E402

LIGHTS = {"front": {}, "back": {"lights.0.direction": (0.15, 0.3, -0.95)}}  # the key behind the head


def pass_ms(rep, name: str) -> float:
    return sum(p.ms or 0.0 for p in rep.passes if p.name == name and p.status == "ran")


def skipped_share(ctx, s) -> tuple[float, int]:
    """(share of the transmitted map's island texels skipped, island texels), from a marked render."""
    deon_passes.TSM_SKIP_MARK = True
    r = Renderer(ctx)
    try:
        r.render(s)
        g = r.graph("deon")
        t = g.read(deon_passes.TRANSMITTED)[..., :3]
        n = t.shape[0]
        covered = g.read(f"texel_surface_{n}_p")[..., 3] != 0
        return float(((t == -1.0).all(axis=-1) & covered).sum() / max(covered.sum(), 1)), int(covered.sum())
    finally:
        r.release()
        deon_passes.TSM_SKIP_MARK = False


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--maps", type=int, default=1024)
    ap.add_argument("--size", type=int, default=640)
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--scenes", default="head,scan")
    ap.add_argument("--lights", default="front,back")
    args = ap.parse_args()
    ctx = headless_context()
    print(f"# transmitted light, skip on (A) / off (B) — {describe(ctx)}; load {os.getloadavg()[0]:.1f} at start")
    scenes = {k: v for k, v in shared_scenes().items() if k in args.scenes.split(",")}
    print("| scene | light | skipped | transmitted A ms (copies) | B ms (copies) | A / B | tsm_max ms | "
          "light move A ms (x Phong) | B ms (x Phong) | Phong ms | copy ms | load |")
    print("| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |")
    for scene_name, scene in scenes.items():
        for light in args.lights.split(","):
            extra = {**{k: list(v) for k, v in LIGHTS[light].items()}}
            s = with_values(settings_for("deon", "head", args.size, args.maps), {**scene, **extra})
            phong = with_values(settings_for("phong", "head", args.size, args.maps), {**scene, **extra})
            share, covered = skipped_share(ctx, s)
            ra, rb = Renderer(ctx), Renderer(ctx)
            try:
                deon_passes.TSM_SKIP = True
                ra.render(s, force=True)
                deon_passes.TSM_SKIP = False
                rb.render(s, force=True)
                ra.render(phong, force=True)
                fa, fb, ta, tb, tm, ph, cp = [], [], [], [], [], [], []
                for k in range(args.repeats):
                    deon_passes.TSM_SKIP = True
                    ms, rep = light_frame(ra, s, k)
                    fa.append(ms)
                    ta.append(pass_ms(rep, "deon_transmitted"))
                    tm.append(pass_ms(rep, "deon_tsm_max"))
                    deon_passes.TSM_SKIP = False
                    ms, rep = light_frame(rb, s, k)
                    fb.append(ms)
                    tb.append(pass_ms(rep, "deon_transmitted"))
                    deon_passes.TSM_SKIP = True
                    ph.append(light_frame(ra, phong, k)[0])
                    cp.append(copy_draw_ms(ra, args.maps, 3))
            finally:
                deon_passes.TSM_SKIP = True
                ra.release()
                rb.release()
            med = statistics.median
            c, p = med(cp), med(ph)
            print(f"| {scene_name} | {light} | {100 * share:.0f} % of {covered} | {med(ta):.0f} ({med(ta) / c:.1f}) | "
                  f"{med(tb):.0f} ({med(tb) / c:.1f}) | {med(ta) / med(tb):.2f} | {med(tm):.1f} | "
                  f"{med(fa):.0f} ({med(fa) / p:.2f}) | {med(fb):.0f} ({med(fb) / p:.2f}) | {p:.0f} | {c:.1f} | "
                  f"{os.getloadavg()[0]:.1f} |", flush=True)


if __name__ == "__main__":
    main()
