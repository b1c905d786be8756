"""Penner & Borshukov's pre-integrated skin's section."""
from __future__ import annotations

from pydantic import Field

from skinviewer.ground.sections.base import Section


class PennerSettings(Section):
    """Pre-integrated skin (Penner & Borshukov, GPU Pro 2, 2011): the profile in use (deon.gaussians)
    integrated around rings of every curvature, and across shadow penumbrae, into lookup tables."""
    lut_size: int = Field(64, ge=8, le=512, description="texels per side of the ring and penumbra tables")
    max_curvature: float = Field(
        2.0, gt=0.0, le=50.0, description="the ring table's curvature range, 1/r in mm^-1 (2: down to r = 0.5 mm)")
    curvature_scale: float = Field(
        1.0, ge=0.0, le=20.0, description="multiplies the mesh's curvature (0: flat skin, N.L only)")
    penumbra: bool = Field(True, description="shadow scattering: the PCF penumbra diffused by the profile")
    penumbra_max_mm: float = Field(
        10.0, gt=0.0, le=1000.0, description="the penumbra table's range of penumbra widths, mm")
