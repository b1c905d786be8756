"""Gosselin et al. 2004 (seed 000 eq. 8-19, seed 002 §14.3): shadowed light map, iterated Poisson
blurs with a per-region kernel, Kelemen/Szirmay-Kalos specular."""
from __future__ import annotations

from skinviewer.passes.gosselin import (
    SIZE,
    GosselinFinalPass,
    GosselinLightMapPass,
    GosselinRadiusMapPass,
    PoissonBlurPass,
)
from skinviewer.passes.luts import BeckmannLutPass
from skinviewer.passes.output import OutputPass
from skinviewer.passes.texture_space import GutterMapPass
from skinviewer.techniques.base import Technique, shadow_passes


def build():
    return shadow_passes() + [
        GutterMapPass(SIZE), GosselinLightMapPass(), GosselinRadiusMapPass(), PoissonBlurPass(),
        BeckmannLutPass(), GosselinFinalPass(), OutputPass("lit"),
    ]


def sweep(quick: bool):
    """Light-map size and the number of Poisson blur iterations (seed 000 eq. 11-13)."""
    if quick:
        return [(f"map{n} it{k}", {"gosselin.light_map_size": n, "gosselin.iterations": k})
                for n, k in ((512, 4), (1024, 2), (1024, 4))]
    return [(f"map{n} it{k}", {"gosselin.light_map_size": n, "gosselin.iterations": k})
            for n in (512, 1024, 2048) for k in (1, 2, 4, 8)]


TECHNIQUE = Technique("gosselin", "Gosselin et al. 2004: texture-space Poisson blurs (seed 000 eq. 8-19)", build,
                      sweep)
