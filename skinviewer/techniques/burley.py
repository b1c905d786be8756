"""Golubev 2018 (Unity HDRP): Burley normalized diffusion sampled on a camera-facing disk in screen space
(seed 001 §3.4, eq. 2.83-2.89, 3.9-3.13; spec §5): importance-sampled radii, golden-angle directions with a
per-pixel rotation, depth-aware weights, normalisation by the weight sum, the pixel cutoff and HDRP's
area-following sample budget; the frame's sample count summed on the GPU."""
from __future__ import annotations

from skinviewer.passes.burley import (
    BLURRED,
    COUNT,
    BurleyBlurPass,
    BurleyCountPass,
    BurleyOutputPass,
    BurleyViewPass,
)
from skinviewer.passes.luts import BeckmannLutPass  # specular.mode = beckmann_lut (pruned otherwise)
from skinviewer.passes.screen_space import CombinePass, screen_lighting
from skinviewer.techniques.base import Technique, shadow_passes


def build():
    return shadow_passes() + [BeckmannLutPass(), *screen_lighting(burley=True), BurleyBlurPass("golubev"), BurleyCountPass(), CombinePass(BLURRED),
                              BurleyViewPass(), BurleyOutputPass("lit")]


def sweep(quick: bool):
    counts = (12, 22) if quick else (6, 8, 12, 16, 22, 30)
    return [(f"n={n}", {"burley.samples": n}) for n in counts]


TECHNIQUE = Technique("burley", "Golubev 2018 (HDRP): Burley normalized diffusion, screen-space disk sampling "
                                "(seed 001 §3.4, eq. 3.9-3.13)", build, sweep, targets=("image", COUNT))
