"""Jimenez et al. 2009 (seed 001 §3.2, eq. 3.2): screen-space sum-of-Gaussians diffusion, one
separable blur per Gaussian of ``deon.gaussians``, width scaled by depth and depth gradient,
incremental (seed 000 eq. 24); Jimenez 2010 transmittance in the lighting pass."""
from __future__ import annotations

import functools

from skinviewer.ground.settings import Settings
from skinviewer.passes.luts import BeckmannLutPass  # specular.mode = beckmann_lut (pruned otherwise)
from skinviewer.passes.output import OutputPass
from skinviewer.passes.screen_space import CombinePass, screen_lighting
from skinviewer.passes.screen_space.jimenez2009 import (
    MAX_GAUSSIANS,
    SUM,
    SsssBlurPass,
    SsssSumPass,
)
from skinviewer.physics.diffusion import profile
from skinviewer.physics.fitting import fit_gaussians
from skinviewer.techniques.base import Config, Technique, shadow_passes


def build():
    return (shadow_passes() + [BeckmannLutPass(), *screen_lighting()] + [SsssBlurPass(i) for i in range(MAX_GAUSSIANS)]
            + [SsssSumPass(), CombinePass(SUM), OutputPass("lit")])


@functools.lru_cache(maxsize=8)
def refit(k: int) -> tuple:
    """The default 6-Gaussian skin profile refitted with k Gaussians (seed 001 eq. 3.1 fit, each
    channel normalised to 1 as d'Eon's table): k blurs instead of 6."""
    gs = [(g.variance, g.weights) for g in Settings().deon.gaussians]
    fit = fit_gaussians(lambda r: profile(r, gs), k)
    return tuple((float(v), tuple(float(x) for x in w)) for v, w in fit.table(normalize=True))


def sweep(quick: bool) -> list[Config]:
    """Gaussian count (the profile refitted with k Gaussians: k blurs) x taps per 1-D pass."""
    def gaussians(k):
        return {} if k == 6 else {"deon.gaussians": [{"variance": v, "weights": list(w)} for v, w in refit(k)]}
    if quick:
        return [("6g-7t", {}), ("3g-7t", gaussians(3))]
    return [(f"{k}g-{t}t", {**gaussians(k), "ssss.taps": t}) for k in (2, 3, 4, 6) for t in (7, 11, 17)]


TECHNIQUE = Technique("ssss", "Jimenez et al. 2009: screen-space sum-of-Gaussians (seed 001 §3.2, eq. 3.2)",
                      build, sweep)
