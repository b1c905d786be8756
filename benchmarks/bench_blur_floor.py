"""d'Eon's blur chain against its floor (issue 27, "Also asked"), side by side in one run: one
separable blur direction (its seam fill included) and the summed step in plain copies of the same
size and format, d'Eon's light-move frame in Phong's, and both at 512^2 / 1024^2 / 2048^2 maps.

    python benchmarks/bench_blur_floor.py [--maps 512 1024 2048] [--size 640] [--repeats 3]
                                          [--set deon.skip_gutters=false ...]
    python benchmarks/bench_blur_floor.py --compute [--maps 1024] [--repeats 5]

--compute (issue 27, render.compute_blur): one blur direction as fragment draws (off) and as compute passes
(on), interleaved light-move frames of the defaults in one run, in plain copies; every separable blur's
output and the image compared between the two (max |difference|). On llvmpipe compute is slower (auto
keeps the fragment draws there); on a GL 4.3 GPU auto picks compute.

Each row runs "before" (every blur step at the map's size, deon.half_res_above_texels = 0, and the
island tiles drawn one 16^2 quad each: passes.deon.TILE_RECTS off, session 4's code), "unsplit" (the
defaults with every blur tile zone-checked and every fill tile seam-filled: session 5's code) and
"after" (the defaults: wide steps on a half-size map, the tiles merged into rectangles and split by
passes.deon.zone_split / seam_split),
interleaved with Phong and with plain full-screen copies (shaders/copy.frag, RGBA32F, the map size
and half of it), so that load on the machine hits all alike. Sync timing (glFinish + wall clock: llvmpipe's timer
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

import skinviewer.passes.deon as deon_passes  # noqa: E402
from skinviewer.engine.renderer import Renderer  # noqa: E402
from skinviewer.ground.settings import with_values  # noqa: E402
from skinviewer.kernel.gl import describe, headless_context  # noqa: E402

CONFIGS = {"before": {"deon.half_res_above_texels": 0.0}, "unsplit": {}, "after": {}}
RECTS = {"before": False, "unsplit": True, "after": True}  # passes.deon.TILE_RECTS per configuration
# "unsplit": the defaults with every blur tile zone-checked and every fill tile seam-filled (passes.deon
# zone_split / seam_split off: session 5's code); "after": the defaults
SPLITS = {"before": False, "unsplit": False, "after": True}
ZONE_SPLIT, SEAM_SPLIT = deon_passes.zone_split, deon_passes.seam_split


def use(config: str) -> None:
    """passes.deon's switches for a configuration (TILE_RECTS, the tile splits)."""
    deon_passes.TILE_RECTS = RECTS.get(config, True)
    on = SPLITS.get(config, True)
    deon_passes.zone_split = ZONE_SPLIT if on else (lambda *a, **k: None)
    deon_passes.seam_split = SEAM_SPLIT if on else (lambda *a, **k: None)


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


def blur_figures(rep) -> tuple[float, float, int, float]:
    """(ms per separable blur direction with its seam fill, summed-step ms, directions, separable ms) of a
    report."""
    sep, dirs, summed = 0.0, 0, 0.0
    for p in rep.passes:
        if not p.name.startswith("deon_blur_") or p.status != "ran" or not p.ms:
            continue
        if "sigma_texels" in p.figures:  # the summed step notes its sigma
            summed += p.ms
        else:
            sep += p.ms
            dirs += p.figures.get("directions", p.draws // 2)  # H and V per sub-step (the pass notes it)
    return (sep / dirs if dirs else float("nan")), summed, dirs, sep


def compute_rows(args, extra: dict) -> None:
    """--compute: fragment (render.compute_blur = off) vs compute (on), side by side in one run."""
    import numpy as np

    from skinviewer.kernel.gl import compute_choice
    from skinviewer.physics.diffusion import blur_resource
    ctx = headless_context()
    auto = compute_choice("auto", ctx)[0]
    print(f"# d'Eon blur direction, fragment vs compute — {describe(ctx)}; render.compute_blur = auto picks "
          f"{'compute' if auto else 'fragment'} here; load {os.getloadavg()[0]:.1f} at start")
    print(f"# scene={args.scene} image={args.size}^2 repeats={args.repeats}; light-move frames, sync timing, medians;"
          f" {extra or 'defaults otherwise'}")
    if ctx.version_code < 430:
        print("# no compute shaders on this context (GL < 4.3): nothing to compare")
        return
    use("after")
    hdr = (f"{'maps':>5} {'path':<9} {'light ms':>9} {'blur dir ms':>12} {'/ copy':>7} {'/ half':>7} {'sep ms':>8} "
           f"{'copy ms':>8}")
    lines = []
    for maps in args.maps:
        r = Renderer(ctx)
        s = {m: settings_for("deon", args.scene, args.size, maps, **extra, **{"render.compute_blur": m})
             for m in ("off", "on")}
        for x in s.values():
            r.render(x, force=True)
        m = {k: {"light": [], "dir": [], "sep": []} for k in s}
        copies, halves = [], []
        for k in range(args.repeats):
            for mode, x in s.items():
                ms, rep = light_frame(r, x, k)
                d, _summed, _dirs, sep = blur_figures(rep)
                m[mode]["light"].append(ms)
                m[mode]["dir"].append(d)
                m[mode]["sep"].append(sep)
            copies.append(copy_draw_ms(r, maps, 3))
            halves.append(copy_draw_ms(r, maps // 2, 3))
        copy, half = statistics.median(copies), statistics.median(halves)
        # the same values? every separable blur's output and the image, each path rendered afresh
        got = {}
        for mode, x in s.items():
            rep = r.render(x, force=True)
            names = ["image"] + [blur_resource(int(p.name.rsplit("_", 1)[1])) for p in rep.passes
                                 if p.name.startswith("deon_blur_") and p.status == "ran" and "directions" in p.figures]
            got[mode] = {n: r.read(x, n).astype(np.float64) for n in names}
        diffs = {n: float(np.abs(got["on"][n] - got["off"][n]).max()) for n in got["off"]}
        for mode in s:
            x = {k: statistics.median(v) for k, v in m[mode].items()}
            lines.append(f"{maps:>5} {'fragment' if mode == 'off' else 'compute':<9} {x['light']:9.1f} {x['dir']:12.2f} "
                         f"{x['dir'] / copy:7.2f} {x['dir'] / half:7.2f} {x['sep']:8.1f} {copy:8.2f}")
        lines.append(f"# {maps}^2: max |compute - fragment|: " + ", ".join(f"{n} {v:.2e}" for n, v in diffs.items())
                     + ("" if len(diffs) > 1 else " (no separable blur ran at these maps: every step summed or folded)"))
        r.release()
        r.shaders.release()
    print(f"# load {os.getloadavg()[0]:.1f} at the end")
    print("# blur dir: one separable direction with its seam fill, in plain copies of the full map's size (the "
          "goal's unit, <= 2) and of the half size its wide steps run at")
    print(hdr)
    print("-" * len(hdr))
    print("\n".join(lines))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--maps", type=int, nargs="+", default=[512, 1024, 2048])
    ap.add_argument("--size", type=int, default=640)
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--scene", default="head")
    ap.add_argument("--set", action="append", default=[], help="extra key=value for both configurations")
    ap.add_argument("--compute", action="store_true", help="fragment vs compute blur directions (render.compute_blur)")
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
    if args.compute:
        compute_rows(args, extra)
        return
    ctx = headless_context()
    print(f"# d'Eon blur floor — {describe(ctx)}; load {os.getloadavg()[0]:.1f} at start")
    print(f"# scene={args.scene} image={args.size}^2 repeats={args.repeats}; sync timing, medians; "
          f"before = full-size blurs, one quad per tile; after = the defaults; {extra or 'defaults otherwise'}")
    rows = {}
    for maps in args.maps:
        r = Renderer(ctx)
        s = {c: settings_for("deon", args.scene, args.size, maps, **extra, **v) for c, v in CONFIGS.items()}
        phong = settings_for("phong", args.scene, args.size, maps)
        for c, x in (*s.items(), ("phong", phong)):
            use(c)
            r.render(x, force=True)
        m = {c: {"light": [], "dir": [], "summed": [], "sep": []} for c in (*CONFIGS, "phong")}
        copies, halves, dirs = [], [], {}
        for k in range(args.repeats):
            for c in CONFIGS:
                use(c)
                ms, rep = light_frame(r, s[c], k)
                d, summed, dirs[c], sep = blur_figures(rep)
                m[c]["light"].append(ms)
                m[c]["dir"].append(d)
                m[c]["summed"].append(summed)
                m[c]["sep"].append(sep)
            use("after")
            m["phong"]["light"].append(light_frame(r, phong, k)[0])
            copies.append(copy_draw_ms(r, maps, 3))
            halves.append(copy_draw_ms(r, maps // 2, 3))
        med = {c: {k: statistics.median(v) for k, v in d.items() if v} for c, d in m.items()}
        copy = statistics.median(copies)
        if maps == 1024 or maps == args.maps[-1]:
            for c in CONFIGS:
                use(c)
                rep = light_frame(r, s[c], args.repeats)[1]
                print(f"# {maps}^2 maps, {c}, one light-move frame per pass (plain copies of {copy:.2f} ms): "
                      + ", ".join(f"{p.name} {p.ms / copy:.1f}" for p in rep.passes if p.status == "ran" and p.ms),
                      flush=True)
            use("after")
        rows[maps] = (med, copy, dirs, statistics.median(halves))
        r.release()
        r.shaders.release()
    print(f"# load {os.getloadavg()[0]:.1f} at the end")
    print("# blur dir: one separable direction with its seam fill, in plain copies of the full map's size "
          "(the figure the goal names) and, after, of the half size its wide steps run at; sep: all separable "
          "blur passes of the frame")
    hdr = (f"{'maps':>5} {'config':<7} {'light ms':>9} {'x phong':>8} {'blur dir ms':>12} {'/ copy':>7} "
           f"{'/ half':>7} {'sep ms':>8} {'summed ms':>10} {'/ copy':>7} {'copy ms':>8} {'half ms':>8} {'phong ms':>9}")
    print(hdr)
    print("-" * len(hdr))
    for maps, (med, copy, _dirs, half) in rows.items():
        ph = med["phong"]["light"]
        for c in CONFIGS:
            x = med[c]
            print(f"{maps:>5} {c:<7} {x['light']:9.1f} {x['light'] / ph:8.2f} {x['dir']:12.2f} {x['dir'] / copy:7.2f} "
                  f"{x['dir'] / half:7.2f} {x['sep']:8.1f} {x['summed']:10.1f} {x['summed'] / copy:7.1f} {copy:8.2f} "
                  f"{half:8.2f} {ph:9.1f}")
    sizes = sorted(rows)
    for a, b in zip(sizes, sizes[1:]):
        for c in CONFIGS:
            ga = rows[b][0][c]["light"] / rows[a][0][c]["light"]
            print(f"growth {a}^2 -> {b}^2 maps ({(b / a) ** 2:.0f}x texels), {c}: light-move frame x{ga:.2f}")


if __name__ == "__main__":
    main()
