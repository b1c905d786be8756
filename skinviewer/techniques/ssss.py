"""Jimenez et al. 2009 (seed 001 §3.2, eq. 3.2): screen-space sum-of-Gaussians diffusion, one
separable blur per Gaussian of ``deon.gaussians``, width scaled by depth and depth gradient,
incremental (seed 000 eq. 24); Jimenez 2010 transmittance in the lighting pass."""
from __future__ import annotations

from skinviewer.passes.output import OutputPass
from skinviewer.passes.screen_space import CombinePass, ScreenLightingPass
from skinviewer.passes.screen_space.jimenez2009 import MAX_GAUSSIANS, SUM, SsssBlurPass, SsssSumPass
from skinviewer.techniques.base import Config, Technique, shadow_passes


def build():
    return (shadow_passes() + [ScreenLightingPass()] + [SsssBlurPass(i) for i in range(MAX_GAUSSIANS)]
            + [SsssSumPass(), CombinePass(SUM), OutputPass("lit")])


def sweep(quick: bool) -> list[Config]:
    """Gaussian count (blurs) x taps per 1-D pass."""
    if quick:
        return [("6g-7t", {}), ("3g-7t", {"ssss.gaussians": 3})]
    return [(f"{g}g-{t}t", {"ssss.gaussians": g, "ssss.taps": t}) for g in (2, 3, 4, 6) for t in (7, 11, 17)]


TECHNIQUE = Technique("ssss", "Jimenez et al. 2009: screen-space sum-of-Gaussians (seed 001 §3.2, eq. 3.2)",
                      build, sweep)
