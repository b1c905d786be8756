"""Translucency from the environment (issue 32) against the ground truth on a back-lit flap: the
`backlit-ear` scene (1.5-6 mm thick) with the studio environment turned so its key soft box is behind,
no other light; each technique with its environment translucency off and on.

    python3 benchmarks/bench_env_translucency.py [--size 64] [--yaw 180] [--techniques deon,ssss] [--form printed]

Off: deon.tsm=false / transmittance.enabled=false. The truth (skinviewer.engine.reference, cached on disk)
takes ~4 min at 64x64 on a loaded 2-core VM. Never asserted: a measurement.
"""
from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "tests"))

from helpers import small_settings  # noqa: E402

from skinviewer.engine.bench import compare_mask, linear_image  # noqa: E402
from skinviewer.engine.reference import compute_reference  # noqa: E402
from skinviewer.engine.renderer import Renderer  # noqa: E402
from skinviewer.kernel.gl import headless_context  # noqa: E402
from skinviewer.physics.metrics import image_error  # noqa: E402


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--size", type=int, default=64)
    ap.add_argument("--yaw", type=float, default=180.0)
    ap.add_argument("--techniques", default="deon,ssss")
    ap.add_argument("--form", default="printed")
    args = ap.parse_args()
    ctx = headless_context()
    r = Renderer(ctx)
    lights = [{"kind": "environment", "environment": "studio", "yaw": args.yaw, "cast_shadow": False}]
    base = small_settings("backlit-ear", "ssss", args.size, lights=lights)
    t = time.perf_counter()
    ref = compute_reference(base)
    print(f"truth {time.perf_counter() - t:.0f} s", ref.meta.get("env"), flush=True)
    for tech in args.techniques.split(","):
        for on in (False, True):
            s = small_settings("backlit-ear", tech, args.size, **{"lights": lights, "transmittance.enabled": on,
                                                                  "deon.tsm": on, "transmittance.form": args.form})
            r.render(s)
            img, cov = linear_image(r, s)
            m = compare_mask(ref.mask, cov)
            e = image_error(img, ref.lit, m)
            ratio = img[m].sum(0) / ref.lit[m].sum(0)
            print(f"{tech:8s} env translucency {'on ' if on else 'off'}: RMS R/G/B "
                  f"{' / '.join(f'{100 * x:.2f}' for x in e.rms)} %  DSSIM {e.dssim:.4f}  "
                  f"mean image/truth R,G,B {np.round(ratio, 3)}", flush=True)
    r.release()


if __name__ == "__main__":
    main()
