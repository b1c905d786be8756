"""d'Eon's blur chain against its floor (issue 27, "Also asked"), side by side in one run: one
separable blur direction (its seam fill included) and the summed step in plain copies of the same
size and format, d'Eon's light-move frame in Phong's, and both at 512^2 / 1024^2 / 2048^2 maps.

    python benchmarks/bench_blur_floor.py [--maps 512 1024 2048] [--size 640] [--repeats 3]
                                          [--set deon.skip_gutters=false ...]

Each row runs "before" (deon.skip_gutters off: every blur and its fill over the whole map) and
"after" (on: the blurs and the summed step shade the island tiles, the seam fill dilates),
interleaved with Phong and with a plain full-screen copy (shaders/copy.frag, RGBA32F, the map size),
so that load on the machine hits all alike. Sync timing (glFinish + wall clock: llvmpipe's timer
queries are not trustworthy), medians over --repeats. A light move re-runs the light's shadow map
and everything after it; mesh-only passes stay cached (bench_frames.light_ms).
"""
from __future__ import annotations

import argparse
import os
import statistics
import sys

sys.path.insert(0, os.path.dirname(__file__))

from bench_frames import copy_draw_ms, settings_for  # noqa: E402

from skinviewer.engine.renderer import Renderer  # noqa: E402
from skinviewer.ground.settings import with_values  # noqa: E402
from skinviewer.kernel.gl import describe, headless_context  # noqa: E402

CONFIGS = {"before": {"deon.skip_gutters": False}, "after": {"deon.skip_gutters": True}}


def light_frame(r: Renderer, s, k: int):
    """(ms, report) of a frame after the key light moved, from the base frame (untimed)."""
    import time
    d = s.lights[0].direction
    s2 = with_values(s, {"lights.0.direction": (d[0] + 0.02 * (k + 1), d[1], d[2])})
    r.render(s)
    r.ctx.finish()
    t0 = time.perf_counter()
    rep = r.render(s2)
    r.ctx.finish()
    return (time.perf_counter() - t0) * 1000.0, rep


def blur_figures(rep) -> tuple[float, float, int]:
    """(ms per separable blur direction with its seam fill, summed-step ms, directions) of a report."""
    sep, dirs, summed = 0.0, 0, 0.0
    for p in rep.passes:
        if not p.name.startswith("deon_blur_") or p.status != "ran" or not p.ms:
            continue
        if "sigma_texels" in p.figures:  # the summed step notes its sigma
            summed += p.ms
        else:
            sep += p.ms
            dirs += p.figures.get("directions", p.draws // 2)  # H and V per sub-step (the pass notes it)
    return (sep / dirs if dirs else float("nan")), summed, dirs


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--maps", type=int, nargs="+", default=[512, 1024, 2048])
    ap.add_argument("--size", type=int, default=640)
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--scene", default="head")
    ap.add_argument("--set", action="append", default=[], help="extra key=value for both configurations")
    args = ap.parse_args()
    extra = {}
    for kv in args.set:
        k, v = kv.split("=", 1)
        extra[k] = {"true": True, "false": False}.get(v.lower(), v)
        if isinstance(extra[k], str):
            try:
                extra[k] = float(v) if "." in v else int(v)
            except ValueError:
                pass
    ctx = headless_context()
    print(f"# d'Eon blur floor — {describe(ctx)}; load {os.getloadavg()[0]:.1f} at start")
    print(f"# scene={args.scene} image={args.size}^2 repeats={args.repeats}; sync timing, medians; "
          f"before = deon.skip_gutters off, after = on; {extra or 'defaults otherwise'}")
    rows = {}
    for maps in args.maps:
        r = Renderer(ctx)
        s = {c: settings_for("deon", args.scene, args.size, maps, **extra, **v) for c, v in CONFIGS.items()}
        phong = settings_for("phong", args.scene, args.size, maps)
        for x in (*s.values(), phong):
            r.render(x, force=True)
        m = {c: {"light": [], "dir": [], "summed": []} for c in (*CONFIGS, "phong")}
        copies, dirs = [], {}
        for k in range(args.repeats):
            for c in CONFIGS:
                ms, rep = light_frame(r, s[c], k)
                d, summed, dirs[c] = blur_figures(rep)
                m[c]["light"].append(ms)
                m[c]["dir"].append(d)
                m[c]["summed"].append(summed)
            m["phong"]["light"].append(light_frame(r, phong, k)[0])
            copies.append(copy_draw_ms(r, maps, 3))
        med = {c: {k: statistics.median(v) for k, v in d.items() if v} for c, d in m.items()}
        copy = statistics.median(copies)
        if maps == 1024 or maps == args.maps[-1]:
            rep = light_frame(r, s["after"], args.repeats)[1]
            print(f"# {maps}^2 maps, after, one light-move frame per pass (plain copies of {copy:.2f} ms): "
                  + ", ".join(f"{p.name} {p.ms / copy:.1f}" for p in rep.passes if p.status == "ran" and p.ms),
                  flush=True)
        rows[maps] = (med, copy, dirs)
        r.release()
        r.shaders.release()
    print(f"# load {os.getloadavg()[0]:.1f} at the end")
    hdr = (f"{'maps':>5} {'config':<7} {'light ms':>9} {'x phong':>8} {'blur dir ms':>12} {'/ copy':>7} "
           f"{'summed ms':>10} {'/ copy':>7} {'copy ms':>8} {'phong ms':>9}")
    print(hdr)
    print("-" * len(hdr))
    for maps, (med, copy, _dirs) in rows.items():
        ph = med["phong"]["light"]
        for c in CONFIGS:
            x = med[c]
            print(f"{maps:>5} {c:<7} {x['light']:9.1f} {x['light'] / ph:8.2f} {x['dir']:12.2f} {x['dir'] / copy:7.2f} "
                  f"{x['summed']:10.1f} {x['summed'] / copy:7.1f} {copy:8.2f} {ph:9.1f}")
    sizes = sorted(rows)
    for a, b in zip(sizes, sizes[1:]):
        for c in CONFIGS:
            ga = rows[b][0][c]["light"] / rows[a][0][c]["light"]
            print(f"growth {a}^2 -> {b}^2 maps ({(b / a) ** 2:.0f}x texels), {c}: light-move frame x{ga:.2f}")


if __name__ == "__main__":
    main()
