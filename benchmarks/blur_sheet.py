"""A before/after sheet of d'Eon at the defaults (640^2 view, 1024^2 maps): the default head and the scan,
front / three-quarter / back-lit (camera 60,5 as notes/fidelity.md), each row full-size blurs (before,
deon.half_res_above_texels = 0) | the defaults (after) | |after - before| x 10, with the largest 8-bit
difference printed per view. For looking at seams, lines and halos, not a measurement.

    python benchmarks/blur_sheet.py --out /tmp/blur_sheet.png [--maps 1024] [--size 640] [--before one-pass-sum]

--before one-pass-sum: before = the summed step in one pass (passes.deon.SPLIT_SUM off, deon_surface_gather.frag),
after = the defaults (its weights kept, deon_gather_sum.frag; issue 27).
"""
from __future__ import annotations

import argparse
import os
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, os.path.dirname(__file__))

from bench_fidelity import SCAN, SCAN_VALUES  # noqa: E402
from bench_frames import settings_for  # noqa: E402
from PIL import Image  # noqa: E402

from skinviewer.engine.renderer import Renderer  # noqa: E402
from skinviewer.ground.settings import with_values  # noqa: E402
from skinviewer.kernel.gl import headless_context  # noqa: E402

VIEWS = {"front": (0.0, 5.0), "3/4": (35.0, 5.0), "back-lit": (60.0, 5.0)}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--out", required=True)
    ap.add_argument("--maps", type=int, default=1024)
    ap.add_argument("--size", type=int, default=640)
    ap.add_argument("--before", choices=("full-size-blurs", "one-pass-sum"), default="full-size-blurs")
    args = ap.parse_args()
    import skinviewer.passes.deon as deon_passes
    r = Renderer(headless_context())
    rows = []
    for scene, extra in (("head", {}), ("scan", SCAN_VALUES)):
        if scene == "scan" and not SCAN.is_file():
            print(f"# no scan at {SCAN}: head only")
            continue
        base = settings_for("deon", "head", args.size, args.maps, **extra)
        for view, (yaw, pitch) in VIEWS.items():
            s = with_values(base, {"camera.yaw": yaw, "camera.pitch": pitch})
            imgs = []
            for side in (0, 1):
                if args.before == "one-pass-sum":
                    x = s
                    deon_passes.SPLIT_SUM = bool(side)  # a forced run reflects every pass afresh
                else:
                    x = with_values(s, {"deon.half_res_above_texels": (0.0, base.deon.half_res_above_texels)[side]})
                r.render(x, force=True)
                imgs.append(np.flipud(np.clip(r.read(x, "image")[..., :3], 0.0, 1.0)))
            a, b = (np.round(i * 255.0) for i in imgs)
            d = np.abs(a - b)
            print(f"{scene} {view}: max {d.max():.0f} levels, {100 * (d.max(-1) > 1).mean():.2f} % of pixels > 1 level")
            rows.append(np.concatenate([a, b, np.clip(d * 10, 0, 255)], axis=1))
    Image.fromarray(np.concatenate(rows, axis=0).astype(np.uint8)).save(Path(args.out))
    print(f"# sheet: {args.out} (rows: head, then the scan, front / 3/4 / back-lit; columns: before | after | diff x10)")


if __name__ == "__main__":
    main()
