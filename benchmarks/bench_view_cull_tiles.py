"""deon.view_cull's needed sets (notes/deon_light_move.md section 17): per scene and view, the share of each
texture-space map's tiles the view needs (passes/view_cull.stage_needs, recorded as the passes ask it), at the
defaults (640^2 view, 1024^2 maps): the default view, a zoomed-in one and the view from behind, on the head and
the shared scan. No timing: the sets depend on the mesh, the view and the light only.

    PYTHONPATH=. xvfb-run -a -s "-screen 0 1280x800x24" python3 benchmarks/bench_view_cull_tiles.py [--maps 1024]
"""
from __future__ import annotations

import argparse
import os
import sys

sys.path.insert(0, os.path.dirname(__file__))
sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))

from bench_frames import settings_for  # noqa: E402

import skinviewer.passes.view_cull as view_cull  # noqa: E402
from skinviewer.engine.renderer import Renderer  # noqa: E402
from skinviewer.ground.settings import with_values  # noqa: E402
from skinviewer.kernel.gl import headless_context  # noqa: E402

SCAN = os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "..", "shared", "assets",
                    "lee-perry-smith", "LeePerrySmith.glb")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--maps", type=int, default=1024)
    ap.add_argument("--size", type=int, default=640)
    args = ap.parse_args()
    seen: dict[str, tuple] = {}
    ask = view_cull.stage_needs

    def recorded(ec, token, n, m):
        out = ask(ec, token, n, m)
        seen["last"] = (token, out)
        return out
    view_cull.stage_needs = recorded
    ctx = headless_context()
    scenes = [("head", {}, 180.0)]
    if os.path.isfile(SCAN):
        scenes.append(("scan", {"scene.mesh": SCAN, "scene.mm_per_unit": 48.0}, 4.0))
    print("scene view                    F     " + "  ".join(f"{k:>11}" for k in
          ("transmitted", "blur_5", "blur_4", "blur_3", "irradiance")))
    for name, extra, near in scenes:
        r = Renderer(ctx)
        s = settings_for("deon", "head", args.size, args.maps, **extra, **{"deon.view_cull": "view"})
        for label, view in (("default", s), (f"zoomed (distance {near:g})", with_values(s, {"camera.distance": near})),
                            ("from behind (yaw 180)", with_values(s, {"camera.yaw": 180.0}))):
            r.render(view, force=True)
            token, need = seen["last"]
            shares = [need.get(k) for k in ("deon_transmitted", "blur_5", "blur_4", "blur_3", "deon_irradiance")]
            print(f"{name:<5} {label:<24} {token.mask.mean():.2f}  " + "  ".join(
                f"{(v.mean() if v is not None else float('nan')):11.2f}" for v in shares), flush=True)
        r.release()


if __name__ == "__main__":
    main()
