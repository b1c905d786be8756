"""Where d'Eon's DSSIM with the environment comes from (issue 32 item 4): the preset's studio + key against
its truth, beside the key alone against its own, split into the pixels the key lights and those it leaves
dark (where a black pair is a perfect SSIM window).

    python3 benchmarks/bench_env_dssim.py [--size 96] [--scan]

The truths are skinviewer.engine.reference's (cached on disk; the environment's takes 5-15 min at 96x96 here).
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "benchmarks"))

from bench_envlight import key_only  # noqa: E402

from skinviewer.engine.bench import compare_mask, linear_image  # noqa: E402
from skinviewer.engine.reference import compute_reference  # noqa: E402
from skinviewer.engine.renderer import Renderer  # noqa: E402
from skinviewer.ground.settings import load_preset, with_values  # noqa: E402
from skinviewer.kernel.gl import headless_context  # noqa: E402
from skinviewer.physics.metrics import dssim_map, image_error  # noqa: E402


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--size", type=int, default=96)
    ap.add_argument("--scan", action="store_true", help="the Lee Perry-Smith scan instead of the default head")
    args = ap.parse_args()
    base = with_values(load_preset(ROOT / "presets" / "studio-environment.json"),
                       {"render.width": args.size, "render.height": args.size, "technique": "deon"})
    if args.scan:
        base = with_values(base, {"scene.mesh": str(ROOT.parent / "shared/assets/lee-perry-smith/LeePerrySmith.glb"),
                                  "scene.mm_per_unit": 48.0})
    r = Renderer(headless_context())
    out = {}
    for label, s in (("env+key", base), ("key", key_only(base))):
        ref = compute_reference(s)
        r.render(s)
        img, cov = linear_image(r, s)
        m = compare_mask(ref.mask, cov)
        e = image_error(img, ref.lit, m)
        out[label] = (dssim_map(img, ref.lit), m, ref.lit)
        print(f"{label:8s} RMS {100 * e.rms_mean:.2f} %  DSSIM {e.dssim:.4f}", flush=True)
    (de, me, _), (dk, mk, refk) = out["env+key"], out["key"]
    m = me & mk
    lit = refk.mean(2) > 0.05 * refk.mean(2)[m].max()
    print(f"pixels the key lights ({100 * (m & lit).sum() / m.sum():.0f} %): DSSIM env+key "
          f"{de[m & lit].mean():.4f}, key {dk[m & lit].mean():.4f}")
    print(f"pixels the key leaves dark: DSSIM env+key {de[m & ~lit].mean():.4f}, key {dk[m & ~lit].mean():.4f}")
    r.release()


if __name__ == "__main__":
    main()
