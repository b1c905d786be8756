"""Jimenez et al. 2009 (seed 001 §3.2, eq. 3.2): screen-space sum-of-Gaussians diffusion, one
separable blur per Gaussian, width scaled by depth and depth gradient, incremental."""
from __future__ import annotations

from skinviewer.passes.output import OutputPass
from skinviewer.passes.screen_space import DIFFUSE, CombinePass, ScreenLightingPass
from skinviewer.techniques.base import Technique, shadow_passes


def build():
    return shadow_passes() + [ScreenLightingPass(), CombinePass(DIFFUSE), OutputPass("lit")]


TECHNIQUE = Technique("ssss", "Jimenez et al. 2009: screen-space sum-of-Gaussians (seed 001 §3.2, eq. 3.2)", build)
