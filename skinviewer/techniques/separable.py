"""Jimenez et al. 2015 (seed 001 §3.3): separable subsurface scattering, one pre-integrated
separable kernel (strength/falloff artist model), two 1-D passes, follow-surface depth test and
per-pixel rotation of the inner taps; Jimenez 2010 transmittance in the lighting pass."""
from __future__ import annotations

from skinviewer.passes.luts import BeckmannLutPass  # specular.mode = beckmann_lut (pruned otherwise)
from skinviewer.passes.output import OutputPass
from skinviewer.passes.screen_space import CombinePass, screen_lighting
from skinviewer.passes.screen_space.separable import OUTPUT, SeparableBlurPass
from skinviewer.techniques.base import Config, Technique, shadow_passes


def build():
    return shadow_passes() + [BeckmannLutPass(), *screen_lighting(), SeparableBlurPass(), CombinePass(OUTPUT), OutputPass("lit")]


def sweep(quick: bool) -> list[Config]:
    """Taps (the 11/17/25 presets and a free count) x inner-tap rotation."""
    if quick:
        return [("17t-rot0.1", {}), ("11t-rot0", {"separable.taps": 11, "separable.rotation": False})]
    out = []
    for taps in (7, 11, 17, 25):
        for rot in (0.0, 0.1, 0.3):
            out.append((f"{taps}t-rot{rot:g}", {"separable.taps": taps, "separable.rotation": rot > 0,
                                                  "separable.rotation_fraction": rot if rot > 0 else 0.1}))
    return out


TECHNIQUE = Technique("separable", "Jimenez et al. 2015: separable subsurface scattering (seed 001 §3.3)",
                      build, sweep)
