"""d'Eon & Luebke 2007 (seed 000 eq. 20-35, seed 002 §14.4): sum-of-Gaussians diffusion in texture
space, hierarchical separable blurs with stretch correction, rho_dt energy conservation, TSM."""
from __future__ import annotations

from skinviewer.core.constants import MAX_GAUSSIANS
from skinviewer.passes.deon import (
    SIZE,
    DeonFinalPass,
    GaussianBlurPass,
    IrradiancePass,
    StretchPass,
    TsmPass,
)
from skinviewer.passes.luts import BeckmannLutPass
from skinviewer.passes.output import OutputPass
from skinviewer.passes.rho_dt import RhoDtLutPass
from skinviewer.passes.texture_space import GutterMapPass
from skinviewer.techniques.base import Technique, shadow_passes


def build():
    return (shadow_passes()
            + [GutterMapPass(SIZE, name="deon_gutter"), StretchPass(), RhoDtLutPass(), BeckmannLutPass(),
               TsmPass(), IrradiancePass()]
            + [GaussianBlurPass(i) for i in range(MAX_GAUSSIANS)]
            + [GaussianBlurPass(i, chain="stretch") for i in range(MAX_GAUSSIANS)]
            + [DeonFinalPass(), OutputPass("lit")])


TECHNIQUE = Technique("deon", "d'Eon & Luebke 2007: texture-space sum-of-Gaussians diffusion (seed 000 eq. 20-35)",
                      build)
