"""The thesis's contrast-driven two-level sampling, "Golubev Plus" (seed 001 ch. 4, Algorithm 1, eq. 4.1-4.2;
spec §7): 12 base Burley samples, 10 more where the per-channel contrast between the inner and outer ring of
the base samples exceeds 0.25 — plus the variants of ``burley2.mode`` (three-level, nested) and neighbourhood
reuse (``burley2.reuse``)."""
from __future__ import annotations

from skinviewer.passes.burley import (
    BLURRED,
    COUNT,
    BurleyBlurPass,
    BurleyCombinePass,
    BurleyCountPass,
    BurleyOutputPass,
    BurleyReusePass,
    BurleyTemporalPass,
    BurleyViewPass,
)
from skinviewer.passes.luts import BeckmannLutPass  # specular.mode = beckmann_lut (pruned otherwise)
from skinviewer.passes.screen_space import screen_lighting
from skinviewer.techniques.base import Config, Technique, shadow_passes


def build():
    return shadow_passes() + [BeckmannLutPass(), *screen_lighting(burley=True), BurleyBlurPass("two_level"), BurleyReusePass(), BurleyTemporalPass(),
                              BurleyCountPass(), BurleyCombinePass(BLURRED), BurleyViewPass(), BurleyOutputPass("lit")]


def sweep(quick: bool) -> list[Config]:
    if quick:
        return [("thesis 12+10 @0.25", {}), ("12+10 @0.1", {"burley2.threshold": 0.1})]
    out: list[Config] = []
    for base, extra in ((6, 6), (8, 14), (12, 10), (12, 18), (16, 14), (6, 24)):
        for t in (0.0, 0.1, 0.25, 0.5, 1.0):
            out.append((f"{base}+{extra} @{t}", {"burley2.base": base, "burley2.extra": extra, "burley2.threshold": t}))
    out.append(("12+10 equal-count rings @0.25", {"burley2.split": "equal-count"}))
    out.append(("beyond: 8+14 @0.25 reuse 1", {"burley2.base": 8, "burley2.extra": 14, "burley2.reuse": 1}))
    out.append(("beyond mode", {"burley2.mode": "beyond"}))
    out.append(("beyond mode, temporal 16 (still view)", {"burley2.mode": "beyond", "burley2.temporal": 16}))
    return out


TECHNIQUE = Technique("burley2", "Vuletic (thesis, seed 001 ch. 4): contrast-driven two-level Burley sampling "
                                 "(Golubev Plus, Algorithm 1, eq. 4.1-4.2)", build, sweep, targets=("image", COUNT))
