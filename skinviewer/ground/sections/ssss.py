"""Jimenez et al. 2009 screen-space Gaussians' section."""
from __future__ import annotations

from pydantic import Field, field_validator

from skinviewer.ground.sections.base import Section, odd


class SsssSettings(Section):
    """Jimenez et al. 2009 screen-space Gaussians (seed 001 §3.2, eq. 3.2; spec §3): one separable blur per
    Gaussian of ``deon.gaussians``, incremental, width s = alpha / (d + beta |grad d|)."""
    alpha: float = Field(11.0, gt=0.0, le=1000.0, description="global SSS level (eq. 3.2); 11 = the true projection")
    beta: float = Field(800.0, ge=0.0, le=1e5, description="how strongly the depth gradient shrinks the kernel (eq. 3.2)")
    taps: int = Field(7, ge=3, le=63, description="taps per 1-D pass over +-3 sigma (7: d'Eon's kernel)")
    gaussians: int = Field(8, ge=1, le=8, description="blur at most this many Gaussians (the rest: a 1-Gaussian refit is "
                                                       "not done; their weight goes to the widest one kept)")

    _odd_taps = field_validator("taps")(odd)
