"""d'Eon's wide blur steps at half size (deon.half_res_above_texels) judged by the ground truth, side by
side with full-size blurs in one run: the same reference (engine.reference, cached), the same renderer,
red/green/blue RMS and p99 (% of the truth) and DSSIM, with the ruler's uncertainty where the
reference has it (physics.metrics.image_error).

    python benchmarks/bench_half_blurs.py [--size 320] [--maps 512 1024] [--scene head|scan] [--camera 25,5]
"""
from __future__ import annotations

import argparse
import os
import sys

sys.path.insert(0, os.path.dirname(__file__))

from bench_fidelity import SCAN_VALUES  # noqa: E402

from skinviewer.engine.bench import compare_mask, linear_image  # noqa: E402
from skinviewer.engine.reference import compute_reference  # noqa: E402
from skinviewer.engine.renderer import Renderer  # noqa: E402
from skinviewer.ground.settings import Settings, with_values  # noqa: E402
from skinviewer.kernel.gl import headless_context  # noqa: E402
from skinviewer.physics.metrics import image_error  # noqa: E402
from skinviewer.scene.scenes import scene_overrides  # noqa: E402


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--size", type=int, default=320)
    ap.add_argument("--maps", type=int, nargs="+", default=[512, 1024])
    ap.add_argument("--scene", choices=["head", "scan"], default="head")
    ap.add_argument("--camera", default=None, help="yaw,pitch (degrees)")
    ap.add_argument("--half", type=float, default=Settings().deon.half_res_above_texels)
    args = ap.parse_args()
    v = {"scene.name": "head", **scene_overrides("head"), "technique": "deon",
         "render.width": args.size, "render.height": args.size}
    if args.scene == "scan":
        v.update(SCAN_VALUES)
    if args.camera:
        yaw, pitch = (float(x) for x in args.camera.split(","))
        v.update({"camera.yaw": yaw, "camera.pitch": pitch})
    base = with_values(Settings(), v)
    ref = compute_reference(base)
    r = Renderer(headless_context())
    print(f"# {args.scene}, {args.size}^2, camera {base.camera.yaw:g},{base.camera.pitch:g}; half size above "
          f"{args.half:g} mean texels vs full-size blurs; errors against the ground truth (± the ruler's uncertainty)")
    print(f"{'maps':>5} {'blurs':<6} {'RMS % r/g/b':<22} {'p99 % r/g/b':<22} {'DSSIM':>8}")
    for maps in args.maps:
        for label, half in (("full", 0.0), ("half", args.half)):
            s = with_values(base, {"deon.irradiance_size": maps, "deon.half_res_above_texels": half})
            r.render(s, force=True)
            img, cov = linear_image(r, s)
            e = image_error(img, ref.lit, compare_mask(ref.mask, cov), exposure=base.render.exposure,
                            uncertainty=getattr(ref, "uncertainty", None))
            unc = f" (±{100 * max(e.rms_u):.2f} / ±{100 * max(e.p99_u):.1f})" if e.rms_u is not None and e.p99_u is not None else ""
            print(f"{maps:>5} {label:<6} {'/'.join(f'{100 * x:.2f}' for x in e.rms):<22} "
                  f"{'/'.join(f'{100 * x:.1f}' for x in e.p99):<22} {e.dssim:8.4f}{unc}", flush=True)


if __name__ == "__main__":
    main()
