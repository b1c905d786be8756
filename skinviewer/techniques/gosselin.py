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


TECHNIQUE = Technique("gosselin", "Gosselin et al. 2004: texture-space Poisson blurs (seed 000 eq. 8-19)", build)
