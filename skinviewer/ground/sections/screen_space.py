"""The screen-space framework's sections, shared by ssss, separable, burley and burley2: what the lighting pass writes (screen) and Jimenez 2010's transmittance."""
from __future__ import annotations

from typing import Literal

from pydantic import Field, field_validator

from skinviewer.ground.constants import REGIONS
from skinviewer.ground.sections.base import Section


class ScreenSettings(Section):
    """The shared screen-space framework (seed 001 §3.1, §3.6; spec §2): what the lighting pass writes."""
    texturing: Literal["post", "pre", "pre-post"] = Field(
        "pre-post", description="seed 001 §3.6: post = blur E then x albedo; pre = blur E x albedo; "
                                "pre-post = x albedo^mix before the blur and x albedo^(1-mix) after")
    mix: float = Field(0.5, ge=0.0, le=1.0, description="pre-post texturing: the albedo exponent f applied before the blur")
    non_skin_regions: list[str] = Field(
        default_factory=lambda: ["other"],
        description="regions (names in REGIONS) the SSS mask excludes: no blur there and no bleeding into them "
                    "(the default head paints its eyeballs 'other', every skin point a named region); a mesh "
                    "without a region map is all skin")

    @field_validator("non_skin_regions")
    @classmethod
    def _regions(cls, v: list[str]) -> list[str]:
        bad = [k for k in v if k not in REGIONS]
        if bad:
            raise ValueError(f"unknown region(s) {bad}; known: {list(REGIONS)}")
        return v


class TransmittanceSettings(Section):
    """Jimenez et al. 2010 translucency from shadow-map thickness (seed 001 §3.5, eq. 3.14-3.18; spec §6):
    added to the diffuse irradiance of every screen-space technique before its blur."""
    enabled: bool = True
    translucency: float = Field(
        0.83, ge=0.0, le=0.999, description="[SEP] translucency: profile distance = 2.75 (1 - t) x thickness (mm)")
    form: Literal["printed", "exact"] = Field(
        "printed", description="printed: exp(-d^2/v_i) (eq. 3.18, [SEP]); exact: exp(-d^2/(2 v_i))")
    wrap: float = Field(0.0, ge=0.0, le=1.0, description="T(d) x saturate(wrap + L.(-N)): 0 = eq. 3.15; [SEP] uses 0.3 "
                        "(a wrap-lighting glow along the terminator)")
