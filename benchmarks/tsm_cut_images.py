"""What d'Eon's transmitted-light cut changes (issue 27; passes.deon.TSM_CUT: a term below 2^-24 of its lit
point's light counts as 0): at the defaults (640^2 view, 1024^2 maps), for the head and the shared scan
(bench_fidelity.SCAN_VALUES), front- and back-lit (bench_tsm_skip.LIGHTS), one render with the cut and one
without (TSM_CUT off: only what underflows in float32 is skipped, bit for bit the full loops), and for each
of `image` (8-bit), `lit` (RGBA16F), `deon_transmitted` and `deon_diffuse`: how many pixels differ and by
how much. Not a timing.

    python benchmarks/tsm_cut_images.py [--size 640] [--maps 1024] [--scenes head,scan] [--lights front,back]
"""
from __future__ import annotations

import argparse
import os
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(__file__))
sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))

from bench_frames import settings_for  # noqa: E402
from bench_tsm_gather import scenes as shared_scenes  # noqa: E402
from bench_tsm_skip import LIGHTS  # noqa: E402

import skinviewer.passes.deon as deon_passes  # noqa: E402
from skinviewer.engine.renderer import Renderer  # noqa: E402
from skinviewer.ground.settings import with_values  # noqa: E402
from skinviewer.kernel.gl import describe, headless_context  # noqa: E402

NAMES = ("image", "lit", deon_passes.TRANSMITTED, "deon_diffuse")


def render(ctx, s, cut: bool) -> dict[str, np.ndarray]:
    deon_passes.TSM_CUT = cut
    r = Renderer(ctx)
    try:
        r.render(s, force=True)
        g = r.graph("deon")
        return {k: g.read(k) for k in NAMES if k in g.resources()}
    finally:
        r.release()
        deon_passes.TSM_CUT = True


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--size", type=int, default=640)
    ap.add_argument("--maps", type=int, default=1024)
    ap.add_argument("--scenes", default="head,scan")
    ap.add_argument("--lights", default="front,back")
    args = ap.parse_args()
    ctx = headless_context()
    print(f"# the transmitted light's 2^-24 cut against none — {describe(ctx)}")
    print("| scene | light | texture | pixels differing | max abs diff | max value |")
    print("| --- | --- | --- | --- | --- | --- |")
    for name, scene in shared_scenes().items():
        if name not in args.scenes.split(","):
            continue
        for light in args.lights.split(","):
            s = with_values(settings_for("deon", "head", args.size, args.maps),
                            {**scene, **{k: list(v) for k, v in LIGHTS[light].items()}})
            exact, cut = render(ctx, s, False), render(ctx, s, True)
            for k in exact:
                a, b = exact[k].astype(np.float64), cut[k].astype(np.float64)
                d = np.abs(a - b).reshape(-1, a.shape[-1])
                print(f"| {name} | {light} | {k} | {int((d.max(axis=1) > 0).sum())} | {d.max():.3g} | "
                      f"{np.abs(a).max():.3g} |", flush=True)


if __name__ == "__main__":
    main()
