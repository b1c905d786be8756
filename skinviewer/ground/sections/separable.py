"""Jimenez et al. 2015 separable SSS's section."""
from __future__ import annotations

import math

from pydantic import Field, field_validator

from skinviewer.ground.sections.base import Section, Vec3, odd


class SeparableSettings(Section):
    """Jimenez et al. 2015 separable SSS (seed 001 §3.3; spec §4, [SEP] calculateKernel/SSSSBlurPS)."""
    taps: int = Field(17, ge=3, le=63, description="kernel samples (presets 11/17/25)")
    strength: Vec3 = Field((0.48, 0.41, 0.28), description="per-channel lerp identity -> blur ([SEP] demo)")
    falloff: Vec3 = Field((1.0, 0.37, 0.30), description="per-channel profile width ([SEP] demo)")
    width_mm: float = Field(3.0, gt=0.0, le=100.0, description="sssWidth in mm: the kernel's +-3 profile mm span this "
                                                                "(3: the d'Eon profile at its true size)")
    follow_surface: bool = True
    follow_surface_mm: float = Field(
        4.0, gt=0.0, le=1000.0, description="depth difference (mm) at which a tap is fully replaced by the centre colour")
    rotation: bool = Field(True, description="per-pixel random rotation of the inner taps (seed 001 §3.3.4)")
    rotation_fraction: float = Field(
        0.1, ge=0.0, le=1.0, description="rotate taps within this fraction of the kernel width (0.1; 0.3 close-ups)")

    _odd_taps = field_validator("taps")(odd)

    @field_validator("strength", "falloff")
    @classmethod
    def _unit(cls, v: Vec3) -> Vec3:
        if any((not math.isfinite(c)) or c < 0 or c > 10 for c in v):
            raise ValueError("components must be finite and in [0, 10]")
        return v
