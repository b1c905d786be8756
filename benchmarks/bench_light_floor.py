"""Where the floor of d'Eon's light move lies against Phong's (issue 27 "Also asked": <= 3x Phong at the
defaults): the light-move frame of several configurations, each in a renderer of its own, and Phong's,
interleaved in each repeat (the order reversed every other repeat), sync timing, medians; per configuration
the frame, x Phong, and its passes grouped (render.timing = sync: each pass fenced), so the passes a
configuration keeps show what they cost beside the ones it drops.

    python benchmarks/bench_light_floor.py [--repeats 5] [--maps 1024] [--size 640] [--only defaults,...]

The configurations: the defaults; without the summed step (deon.surface_gather_below_texels 0: every
step separable); without the transmitted light (deon.tsm off); both off; the defaults at 512^2 maps
(texture-space maps and shadow maps, Phong's too at that size in its own column)."""
from __future__ import annotations

import argparse
import collections
import os
import statistics
import sys

sys.path.insert(0, os.path.dirname(__file__))
sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))

from bench_blur_floor import light_frame  # noqa: E402
from bench_frames import copy_draw_ms, settings_for  # noqa: E402

from skinviewer.engine.renderer import Renderer  # noqa: E402
from skinviewer.kernel.gl import describe, headless_context  # noqa: E402

CONFIGS: dict[str, tuple[int | None, dict]] = {  # name -> (map size, None: --maps; settings)
    "defaults": (None, {}),
    "no summed step": (None, {"deon.surface_gather_below_texels": 0.0}),
    "no transmitted": (None, {"deon.tsm": False}),
    "neither": (None, {"deon.surface_gather_below_texels": 0.0, "deon.tsm": False}),
    "512^2 maps": (512, {}),
}
GROUPS = (  # (label, pass-name test) in the table's order
    ("irradiance", lambda n: n in ("deon_irradiance", "deon_irradiance_surface")),
    ("summed step", lambda n: False),  # filled from the pass's own figure (sigma_texels), below
    ("separable blurs", lambda n: n.startswith("deon_blur_")),
    ("transmitted", lambda n: n == "deon_transmitted"),
    ("TSM + max map", lambda n: n.startswith("deon_tsm")),
    ("shadow map", lambda n: n.startswith("shadow_")),
    ("combine", lambda n: n == "deon_combine"),
    ("final", lambda n: n.startswith("deon_final")),
    ("output", lambda n: n == "output"),
)


def grouped(rep) -> dict[str, float]:
    out: dict[str, float] = collections.defaultdict(float)
    for p in rep.passes:
        if p.status != "ran" or not p.ms:
            continue
        if p.name.startswith("deon_blur_") and "sigma_texels" in p.figures:
            out["summed step"] += p.ms
            continue
        label = next((g for g, test in GROUPS if test(p.name)), "other")
        out[label] += p.ms
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--maps", type=int, default=1024)
    ap.add_argument("--size", type=int, default=640)
    ap.add_argument("--only", default="", help="comma-separated configuration names (default: all)")
    args = ap.parse_args()
    names = [n for n in CONFIGS if not args.only or n in args.only.split(",")]
    if not names:
        sys.exit(f"--only: none of {args.only!r} is a configuration ({', '.join(CONFIGS)})")
    ctx = headless_context()
    print(f"# d'Eon's light move per configuration — {describe(ctx)}; load {os.getloadavg()[0]:.1f} at start")
    sizes = {n: CONFIGS[n][0] or args.maps for n in names}
    renderers, settings = {}, {}
    for n in names:
        settings[n] = settings_for("deon", "head", args.size, sizes[n], **CONFIGS[n][1])
        renderers[n] = Renderer(ctx)
        renderers[n].render(settings[n], force=True)
    phong_sizes = sorted(set(sizes.values()))
    phong = {m: settings_for("phong", "head", args.size, m) for m in phong_sizes}
    phong_r = {m: Renderer(ctx) for m in phong_sizes}
    for m in phong_sizes:
        phong_r[m].render(phong[m], force=True)
    frames: dict[str, list[float]] = collections.defaultdict(list)
    parts: dict[tuple[str, str], list[float]] = collections.defaultdict(list)
    phongs: dict[int, list[float]] = collections.defaultdict(list)
    copies: list[float] = []
    for k in range(args.repeats):
        for n in (names if k % 2 == 0 else names[::-1]):
            ms, rep = light_frame(renderers[n], settings[n], k)
            frames[n].append(ms)
            g = grouped(rep)
            for label, _ in (*GROUPS, ("other", None)):
                parts[(n, label)].append(g.get(label, 0.0))
        for m in phong_sizes:
            phongs[m].append(light_frame(phong_r[m], phong[m], k)[0])
        copies.append(copy_draw_ms(phong_r[phong_sizes[-1]], args.maps, 3))
    ph = {m: statistics.median(v) for m, v in phongs.items()}
    print(f"# head, {args.size}^2 view, repeats={args.repeats}; load {os.getloadavg()[0]:.1f} at the end; "
          f"Phong's light move {', '.join(f'{v:.0f} ms ({m}^2 maps)' for m, v in ph.items())}; "
          f"a plain copy {statistics.median(copies):.2f} ms ({args.maps}^2)")
    labels = [g for g, _ in GROUPS] + ["other"]
    print(f"{'configuration':<16} {'maps':>5} {'light ms':>9} {'x Phong':>8} " + " ".join(f"{lb[:11]:>11}" for lb in labels))
    for n in names:
        ms = statistics.median(frames[n])
        cells = " ".join(f"{statistics.median(parts[(n, lb)]):11.1f}" for lb in labels)
        print(f"{n:<16} {sizes[n]:>5} {ms:9.0f} {ms / ph[sizes[n]]:8.2f} {cells}")


if __name__ == "__main__":
    main()
