"""Gosselin et al. 2004 (seed 000 eq. 8-19, seed 002 §14.3): shadowed light map, iterated Poisson
blurs with a per-region kernel, Kelemen/Szirmay-Kalos specular."""
from __future__ import annotations

from skinviewer.passes.deon import StretchPass
from skinviewer.passes.gosselin import (
    STRETCH,
    GosselinFinalPass,
    GosselinLightMapPass,
    GosselinRadiusMapPass,
    PoissonBlurPass,
    light_map_size,
)
from skinviewer.passes.luts import BeckmannLutPass
from skinviewer.passes.output import OutputPass
from skinviewer.passes.texture_space import GutterMapPass, TexelSurfacePass
from skinviewer.techniques.base import Technique, shadow_passes


def build():
    return shadow_passes() + [
        GutterMapPass("gosselin_gutter", light_map_size), TexelSurfacePass("gosselin_texel_surface", light_map_size),
        GosselinLightMapPass(), GosselinRadiusMapPass(),
        StretchPass("gosselin_stretch", STRETCH, light_map_size), PoissonBlurPass(),
        BeckmannLutPass(), GosselinFinalPass(), OutputPass("lit"),
    ]


def sweep(quick: bool):
    """Light-map size and the number of Poisson blur iterations (seed 000 eq. 11-13), with the
    printed radii (texels at 1024, eq. 12) and the physical ones (mm from the profile's variance),
    so the Pareto chart compares methods, not units."""
    def rows(pairs, mode):
        tag = "" if mode == "printed" else " mm"
        return [(f"map{n} it{k}{tag}", {"gosselin.light_map_size": n, "gosselin.iterations": k,
                                        "gosselin.radius_mode": mode}) for n, k in pairs]
    pairs = ((512, 4), (1024, 2), (1024, 4)) if quick else [(n, k) for n in (512, 1024, 2048) for k in (1, 2, 4, 8)]
    return rows(pairs, "printed") + rows(pairs, "mm")


TECHNIQUE = Technique("gosselin", "Gosselin et al. 2004: texture-space Poisson blurs (seed 000 eq. 8-19)", build,
                      sweep)
