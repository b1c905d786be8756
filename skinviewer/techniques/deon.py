"""d'Eon & Luebke 2007 (seed 000 eq. 20-35, seed 002 §14.4): sum-of-Gaussians diffusion in texture
space, hierarchical separable blurs with stretch correction, rho_dt energy conservation, TSM."""
from __future__ import annotations

from skinviewer.ground.constants import MAX_GAUSSIANS
from skinviewer.passes.deon import (
    BorderFramePass,
    DeonFinalPass,
    DeonFinalViewPass,
    DiffuseSumPass,
    GatherSurfacePass,
    GatherWeightsPass,
    GaussianBlurPass,
    IrradiancePass,
    IrradianceSurfacePass,
    StretchPass,
    TransmittedPass,
    TsmMaxPass,
    TsmPass,
    map_size,
    transmitted_size,
)
from skinviewer.passes.luts import BeckmannLutPass
from skinviewer.passes.output import OutputPass
from skinviewer.passes.rho_dt import RhoDtLutPass
from skinviewer.passes.texture_space import GutterMapPass, TexelSurfacePass
from skinviewer.techniques.base import Config, Technique, shadow_passes


def build():
    return (shadow_passes()
            + [GutterMapPass("deon_gutter", map_size),
               GutterMapPass("deon_gutter_half", transmitted_size), StretchPass(), RhoDtLutPass(), BeckmannLutPass(),
               TexelSurfacePass("deon_texel_surface", map_size),
               TexelSurfacePass("deon_texel_surface_half", transmitted_size), TsmPass(), TsmMaxPass(), IrradianceSurfacePass(),
               IrradiancePass(), GatherSurfacePass(),
               BorderFramePass()]
            + [GatherWeightsPass(i) for i in range(MAX_GAUSSIANS)]
            + [GaussianBlurPass(i) for i in range(MAX_GAUSSIANS)]
            + [GaussianBlurPass(i, chain="stretch") for i in range(MAX_GAUSSIANS)]
            + [TransmittedPass(), DiffuseSumPass(), DeonFinalViewPass(), DeonFinalPass(), OutputPass("lit")])


def fewer_gaussians(k: int) -> list[dict]:
    """The default six-Gaussian skin profile refitted with k Gaussians (seed 000 eq. 21; the
    sweep's Gaussian-count knob): what dropping blurs costs against the six-Gaussian truth."""
    from skinviewer.ground.settings import Settings
    from skinviewer.physics.diffusion import profile
    from skinviewer.physics.fitting import fit_gaussians
    g = Settings().deon.gaussians
    fit = fit_gaussians(lambda r: profile(r, g), k=k)
    return [{"variance": v, "weights": list(w)} for v, w in fit.table()]


def sweep(quick: bool) -> list[Config]:
    """Irradiance/blur texture size (the blurs' taps are tied to its texels: eq. 25 sub-steps),
    stretch correction, the TSM, and the number of Gaussians (eq. 21)."""
    if quick:
        return ([(f"irr{n}", {"deon.irradiance_size": n}) for n in (256, 512, 1024)]
                + [("irr512 4G", {"deon.irradiance_size": 512, "deon.gaussians": fewer_gaussians(4)})])
    out: list[Config] = [(f"irr{n}", {"deon.irradiance_size": n}) for n in (256, 512, 1024, 2048)]
    out += [("irr1024 no-stretch", {"deon.irradiance_size": 1024, "deon.stretch": False}),
            ("irr1024 no-tsm", {"deon.irradiance_size": 1024, "deon.tsm": False}),
            ("irr1024 tsm512", {"deon.irradiance_size": 1024, "deon.tsm_size": 512}),
            ("irr1024 reuse2", {"deon.irradiance_size": 1024, "deon.reuse_irradiance_below_texels": 2.0})]
    out += [(f"irr1024 {k}G", {"deon.irradiance_size": 1024, "deon.gaussians": fewer_gaussians(k)}) for k in (2, 3, 4)]
    return out


TECHNIQUE = Technique("deon", "d'Eon & Luebke 2007: texture-space sum-of-Gaussians diffusion (seed 000 eq. 20-35)",
                      build, sweep)
