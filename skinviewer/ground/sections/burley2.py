"""The thesis's two-level sampling ("Golubev Plus")'s section; profile and budget from ``burley``."""
from __future__ import annotations

import math
from typing import Literal

from pydantic import Field, field_validator, model_validator

from skinviewer.ground.sections.base import Section, Vec3


class Burley2Settings(Section):
    """The thesis's contrast-driven two-level sampling, "Golubev Plus" (seed 001 ch. 4, Algorithm 1,
    eq. 4.1-4.2; spec §7). Profile and cutoff/budget from ``burley``."""
    mode: Literal["thesis", "three-level", "nested", "beyond"] = Field(
        "thesis", description="thesis: base + extra (Algorithm 1); three-level: a third set when the contrast "
                              "exceeds threshold2 too; nested: the base set is a subset of one (base + extra)-sample "
                              "Golubev set and the extra level completes it ((base+extra)/base odd); beyond: the "
                              "fixed variant that beat Table 4.1's target (9 + 11, equal-count rings, reuse; "
                              "the other fields are ignored)")
    base: int = Field(12, ge=1, le=64, description="base samples (thesis: 12)")
    extra: int = Field(10, ge=1, le=64, description="extra samples where the contrast triggers (thesis: 10)")
    third: int = Field(0, ge=0, le=64, description="three-level mode: samples of the third set")
    threshold: float = Field(
        0.25, ge=-1.0, le=1.0, description="contrast cutoff: extra samples iff C > threshold in any channel "
        "(eq. 4.2; the thesis's 0.25 under either reading, spec §7.4); 1: never, < 0: always")
    threshold2: float = Field(0.5, ge=-1.0, le=1.0, description="three-level mode: cutoff of the third set")
    channel_scale: Vec3 = Field((1.0, 1.0, 1.0), description="per-channel multiplier of the cutoffs")
    split: Literal["half-radius", "area-third", "equal-count"] = Field(
        "half-radius", description="inner/outer ring of the base samples: r <= R/2 (thesis), r <= R/sqrt(3), "
                                   "or the nearer half of the samples")
    contrast: Literal["rings", "minmax"] = Field(
        "rings", description="rings: eq. 4.1 between ring means; minmax: (max-min)/(max+min) of the samples")
    reuse: int = Field(0, ge=0, le=2, description="neighbourhood reuse radius, px (0 off): pool the far samples' "
                                                  "sums of the (2R+1)^2 pixels around (each rotated its disk differently)")
    reuse_split: float = Field(3.0, ge=0.0, le=1000.0,
                               description="reuse: samples at least this many px from the centre are pooled; nearer "
                                           "ones (where a 1-px shift would blur the peaked profile) stay the pixel's own")

    wide_px: float = Field(1e6, gt=0.0, le=1e6, description="kernels at least this wide (filter radius, px) scale "
                                                              "the contrast cutoffs by wide_scale (a footprint LOD)")
    wide_scale: float = Field(1.0, ge=0.0, le=100.0, description="cutoff multiplier for wide kernels")
    temporal: int = Field(0, ge=0, le=64, description="temporal reuse on a still view: frames in each pixel's "
                          "running mean (0 off). Each frame turns the sample disks by a new seed; any change, the "
                          "camera included, restarts the mean; the image refines for this many frames, then stops")

    @field_validator("channel_scale")
    @classmethod
    def _scale(cls, v: Vec3) -> Vec3:
        if any((not math.isfinite(c)) or c < 0 for c in v):
            raise ValueError("channel scales must be finite and >= 0")
        return v

    @model_validator(mode="after")
    def _nested(self) -> Burley2Settings:
        total = self.base + self.extra
        if self.mode == "nested" and (total % self.base or (total // self.base) % 2 == 0):
            raise ValueError(f"nested mode needs (base + extra) / base odd, e.g. 6 + 24 or 10 + 20 (got {self.base} + "
                             f"{self.extra})")
        return self
