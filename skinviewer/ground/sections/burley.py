"""Burley normalized diffusion in screen space (Golubev 2018)'s section."""
from __future__ import annotations

import math
from typing import Literal

from pydantic import Field, field_validator

from skinviewer.ground.sections.base import Section, Vec3, field


class BurleySettings(Section):
    """Burley normalized diffusion in screen space, Golubev 2018 / Unity HDRP (seed 001 §3.4, eq. 2.83-2.89,
    3.9-3.13; spec §5). Profile per channel: d = mfp / s(A) (Christensen's fits), S = 1/d."""
    # Jensen et al. 2001 Skin1 (sigma_s' = 0.74/0.88/1.01, sigma_a = 0.032/0.17/0.48 per mm): dipole total
    # reflectance and diffuse mean free path (eq. 2.87); with eq. 2.88: d = 1.07 / 0.42 / 0.21 mm
    albedo: Vec3 = Field((0.436, 0.227, 0.131), description="surface albedo A per channel (picks s(A), eq. 2.86-2.89)")
    mfp: Vec3 = Field((3.749, 1.473, 0.785), description="mean free path per channel, mm (diffuse mfp for the dmfp fit)")
    fit: Literal["searchlight-dmfp", "searchlight-mfp", "diffuse-transmission", "direct"] = Field(
        "searchlight-dmfp", description="s(A): eq. 2.88 (dmfp), 2.86 (mfp), 2.89 (DST); direct: d = mfp (HDRP-new)")
    scale: float = Field(1.0, gt=0.0, le=100.0, description="multiplies d (HDRP's distance multiplier)")
    samples: int = Field(22, ge=1, le=64, description="Golubev's samples per pixel (thesis: 22; spec §5.2)")
    budget: bool = Field(
        True, description="HDRP adaptive count: n <= floor(kernel area / 4 px) (spec §5.3 step 3); the pixel "
                          "cutoff (kernel under ~1 px: no blur) applies either way")
    view: Literal["image", "extra", "samples"] = Field(
        "image", description="extra: tint pixels that took extra samples (and skipped ones blue); samples: heat map")
    transmission: Literal["closed-form", "thick", "jimenez2010"] = field(
        "closed-form", description="through thin parts, from the shadow-map thickness t (spec §5.4, HDRP): closed-form "
        "T(t) = (e^(-S t) + 3 e^(-S t/3)) / 4, the Burley profile integrated over the plane at depth t (thin mode); "
        "thick: e^(-S t/3) (HDRP's regular mode, no baked thickness); jimenez2010: the Gaussian T(d) of the "
        "`transmittance` section",
        tip=("light through thin parts from the shadow-map thickness t (spec §5.4): closed form (e^(-St) + "
             "3e^(-St/3))/4, HDRP's thick mode e^(-St/3), or Jimenez 2010's"))

    @field_validator("albedo")
    @classmethod
    def _albedo(cls, v: Vec3) -> Vec3:
        if any((not math.isfinite(c)) or c < 0 or c > 1 for c in v):
            raise ValueError("albedo components must be in [0, 1]")
        return v

    @field_validator("mfp")
    @classmethod
    def _mfp(cls, v: Vec3) -> Vec3:
        if any((not math.isfinite(c)) or c <= 0 or c > 1000 for c in v):
            raise ValueError("mean free path components must be in (0, 1000] mm")
        return v
