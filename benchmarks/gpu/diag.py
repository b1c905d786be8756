"""Where two GL implementations disagree (issue 31): the figures behind the suite's GPU-only failures,
printed and written to OUT/diag.txt. `STEPS=diag benchmarks/gpu/run.sh OUT` runs it.

* d'Eon's texel-surface path vs the unwrapped mesh (tests/test_texel_surface.py, head): how many
  texels differ, and whether the shadow test (deon_visibility) differs at them;
* separable's follow-surface identity (tests/test_ssss.py::test_t3_5_follow_surface): the pixels that
  changed, with their depth, mask and diffuse input;
* the laser's power per technique against the beam's pi r^2 I.
"""
from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parents[1]))
sys.path.insert(0, str(HERE.parents[1] / "tests"))

from helpers import small_settings  # noqa: E402

from skinviewer.engine.renderer import Renderer  # noqa: E402
from skinviewer.ground.settings import with_values  # noqa: E402
from skinviewer.kernel.gl import headless_context  # noqa: E402


def texel_surface(r: Renderer, say) -> None:
    base = small_settings("head", "deon", 48)
    maps = {}
    for flag in (False, True):
        s = with_values(base, {"render.texel_surface": flag})
        r.render(s, force=True)
        g = r.graph("deon")
        maps[flag] = {k: g.read(k).astype(np.float64) for k in ("deon_irradiance", "deon_visibility", "deon_stretch",
                                                                  "deon_diffuse", "lit") if k in g.resources()}
    for k in maps[False]:  # each map as the test judges it (max |a - b| over max |a|)
        d = np.abs(maps[False][k] - maps[True][k])
        y, x = np.unravel_index(int(np.argmax(d.max(axis=-1) if d.ndim == 3 else d)), d.shape[:2])
        say(f"  {k}: max |diff| / max |a| = {d.max() / max(np.abs(maps[False][k]).max(), 1e-12):.2e} at texel ({x},{y})"
            f" a {maps[False][k][y, x].round(4)} b {maps[True][k][y, x].round(4)}")
    a, b = maps[False]["deon_irradiance"], maps[True]["deon_irradiance"]
    rel = np.abs(a - b)[..., :3].max(axis=-1) / max(np.abs(a).max(), 1e-12)
    bad = rel > 1e-5  # the test's bound for the irradiance
    say(f"texel surface vs unwrap (head, 256^2 maps): {int(bad.sum())} of {bad.size} texels differ by > 1e-5 of the max;"
        f" max {rel.max() * 100:.2f} %")
    if "deon_visibility" in maps[False] and bad.any():
        va, vb = maps[False]["deon_visibility"], maps[True]["deon_visibility"]
        dv = np.abs(va - vb).max(axis=-1)
        say(f"  at those texels the visibility differs by max {dv[bad].max():.3f}, median {np.median(dv[bad]):.3f};"
            f" texels where visibility differs by > 0.05: {int((dv > 0.05).sum())}")
        ys, xs = np.nonzero(bad)
        for y, x in list(zip(ys, xs))[:8]:
            say(f"  texel ({x},{y}): E unwrap {a[y, x, :3].round(3)} texel {b[y, x, :3].round(3)} "
                f"vis unwrap {va[y, x].round(3)} texel {vb[y, x].round(3)} alpha {a[y, x, 3]:.2f}/{b[y, x, 3]:.2f}")


def follow_surface(r: Renderer, say) -> None:
    from test_ssss import OUT, laser

    from skinviewer.passes.screen_space import DEPTH, DIFFUSE
    s = laser("separable", size=64, distance=30.0, **{"camera.yaw": 35.0, "camera.pitch": 30.0,
                                                        "separable.follow_surface_mm": 1e-4})
    r.render(s, force=True)
    E = r.read(s, DIFFUSE)
    out = r.read(s, OUT["separable"])
    dep = r.read(s, DEPTH)
    diff = np.abs(out[..., :3] - E[..., :3]).max(axis=-1)
    bad = diff > 1e-5 + 1e-5 * np.abs(E[..., :3]).max(axis=-1)
    say(f"separable follow-surface identity: {int(bad.sum())} pixels changed")
    ys, xs = np.nonzero(bad)
    for y, x in list(zip(ys, xs))[:8]:
        say(f"  px ({x},{y}): out {out[y, x, :3].round(4)} E {E[y, x, :3].round(4)} mask {E[y, x, 3]:.2f} "
            f"depth {dep[y, x].round(4)}")


def laser_power(r: Renderer, say) -> None:
    for tech in ("phong", "deon", "ssss", "separable", "burley"):
        s = small_settings("laser", tech, 128)
        beam = s.lights[0]
        r.render_settled(s)
        side = 2.0 * s.camera.distance * math.tan(math.radians(s.camera.fov_y) / 2.0) / 128
        p = r.read(s, "lit")[..., :3].sum(axis=(0, 1)) * side ** 2
        say(f"laser power {tech:<10} {p.round(4)} (beam pi r^2 I = {math.pi * beam.beam_radius ** 2 * beam.intensity:.4f})")


def main() -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("--out", required=True)
    args = ap.parse_args()
    lines: list[str] = []

    def say(text: str) -> None:
        print(text, flush=True)
        lines.append(text)
    ctx = headless_context()
    r = Renderer(ctx)
    for step in (laser_power, texel_surface, follow_surface):
        try:
            step(r, say)
        except Exception as exc:  # one diagnostic failing must not hide the others
            say(f"{step.__name__}: {type(exc).__name__}: {exc}")
    r.release()
    ctx.release()
    (Path(args.out) / "diag.txt").write_text("\n".join(lines) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
