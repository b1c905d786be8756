"""Phong/Blinn-Phong, the baseline without scattering."""
from __future__ import annotations

from skinviewer.ground.sections.base import Section, field


class PhongSettings(Section):
    ambient: float = field(0.03, ge=0.0, le=10.0,
        tip="ambient term (fraction of albedo)")
    specular: float = field(0.25, ge=0.0, le=100.0,
        tip="Blinn-Phong specular intensity")
    shininess: float = field(32.0, ge=1.0, le=4096.0,
        label="shininess",
        unit="exponent",
        tip="Blinn-Phong exponent (higher = tighter highlight)")
