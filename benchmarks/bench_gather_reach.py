"""The summed d'Eon step's reach following sigma (issue 27): physics/surface_gather.gather_blocks_for
against the fixed reach of 5 blocks it replaced, side by side in one run — the summed step's cost
(sync timing: glFinish + wall clock, forced frames, medians), the whole image's difference and each
image's error against the ground truth (skinviewer reference, engine/bench's metrics).

    python benchmarks/bench_gather_reach.py [--size 256] [--maps 1024] [--repeats 3] [--scan]

The default head (``--scan``: the shared scan as well), the default rig and settings but the image size.
"""
from __future__ import annotations

import argparse
import statistics
from unittest import mock

import numpy as np

from skinviewer.engine.bench import compare_mask, linear_image
from skinviewer.engine.reference import compute_reference
from skinviewer.engine.renderer import Renderer
from skinviewer.ground.settings import Settings, with_values
from skinviewer.kernel.gl import describe, headless_context
from skinviewer.passes import deon
from skinviewer.physics.metrics import image_error


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--size", type=int, default=256)
    ap.add_argument("--maps", type=int, default=1024)
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--scan", action="store_true")
    args = ap.parse_args()
    ctx = headless_context()
    r = Renderer(ctx)
    print(f"# the summed step's reach: follows sigma vs fixed 5 blocks — {describe(ctx)}")
    print(f"# image {args.size}^2, maps {args.maps}^2 (the default), sync timing, medians of {args.repeats} forced frames")
    scenes = {"head": {}}
    if args.scan:
        from bench_tsm_gather import scenes as shared
        scenes.update({k: v for k, v in shared().items() if k != "head"})
    print(f"{'scene':<6} {'reach':<12} {'blocks':>6} {'gather ms':>9} {'ratio':>6} {'rms vs truth':>12} {'p99':>7} "
          f"{'max diff (8-bit)':>16}")
    for name, scene in scenes.items():
        s = with_values(Settings(), {**scene, "technique": "deon", "render.width": args.size,
                                     "render.height": args.size, "deon.irradiance_size": args.maps})
        ref = compute_reference(s)
        rows = {}
        for label, patch in (("fixed 5", lambda sigma: 5), ("follows σ", None)):
            ctxm = mock.patch.object(deon, "gather_blocks_for", patch) if patch else mock.patch.object(deon, "_unused", None, create=True)
            with ctxm:
                r.render(s, force=True)
                ms = []
                for _ in range(args.repeats):
                    rep = r.render(s, force=True, timing="sync")
                    ms.append(sum(p.ms or 0.0 for p in rep.passes if p.status == "ran" and p.note.startswith("summed")))
                img, cov = linear_image(r, s)
                shown = r.image(s).astype(np.int16)
                blocks = deon.gather_reach(_Probe(r, s), _step(r, s), args.maps)
            e = image_error(img, ref.lit, compare_mask(ref.mask, cov), exposure=s.render.exposure)
            rows[label] = (statistics.median(ms), float(np.mean(e.rms)), float(np.mean(e.p99)), shown, blocks)
        base = rows["fixed 5"]
        for label, (ms, rms, p99, shown, blocks) in rows.items():
            diff = int(np.abs(shown - base[3]).max())
            print(f"{name:<6} {label:<12} {blocks if label != 'fixed 5' else 5:>6} {ms:9.1f} {ms / base[0]:6.2f} "
                  f"{rms:12.4%} {p99:7.2%} {diff:16d}")


class _Probe:
    """What deon.gather_reach reads of a reflection: the scene."""
    def __init__(self, r, s):
        self.scene = r.scene.gpu


def _step(r, s):
    from skinviewer.physics.diffusion import blur_plan_texels
    texel = deon.mean_texel_mm(r.scene.gpu, s.deon.irradiance_size)
    plan = blur_plan_texels([g.variance for g in s.deon.gaussians], s.deon.reuse_irradiance_below_texels, texel,
                            s.deon.fold_below_texels)
    return next(st for st in plan if deon._gathers(st, s.deon.surface_gather_below_texels, texel))


if __name__ == "__main__":
    main()
