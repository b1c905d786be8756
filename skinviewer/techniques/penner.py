"""Pre-integrated skin (Penner & Borshukov, GPU Pro 2, 2011): the profile in use (deon.gaussians)
integrated around rings of every curvature and across shadow penumbrae, looked up per pixel by N.L,
the mesh's curvature and the PCF shadow value -- no blur pass, Phong's cost plus two table fetches."""
from __future__ import annotations

from skinviewer.passes.luts import BeckmannLutPass
from skinviewer.passes.output import OutputPass
from skinviewer.passes.penner import PennerLutPass, PennerPass
from skinviewer.passes.rho_dt import RhoDtLutPass
from skinviewer.techniques.base import Technique, shadow_passes


def build():
    return shadow_passes() + [PennerLutPass(), RhoDtLutPass(), BeckmannLutPass(), PennerPass(), OutputPass("lit")]


def sweep(quick: bool):
    """The tables' resolution and the curvature scale (Penner's artist knob), with and without
    shadow scattering."""
    if quick:
        return [("lut32", {"penner.lut_size": 32}), ("lut64", {"penner.lut_size": 64}),
                ("lut64 flat", {"penner.lut_size": 64, "penner.curvature_scale": 0.0})]
    return ([(f"lut{n} k{k:g}", {"penner.lut_size": n, "penner.curvature_scale": k})
             for n in (16, 32, 64, 128) for k in (0.5, 1.0, 2.0)]
            + [("lut64 k1 no-penumbra", {"penner.lut_size": 64, "penner.penumbra": False}),
               ("lut64 flat", {"penner.lut_size": 64, "penner.curvature_scale": 0.0})])


TECHNIQUE = Technique("penner", "Penner & Borshukov 2011: pre-integrated skin (ring and penumbra tables)",
                      build, sweep)
