"""Gosselin et al. 2004's section (seed 000 §4.1, eq. 8-19): the light map and its Poisson blurs."""
from __future__ import annotations

from typing import Literal

from pydantic import Field, field_validator

from skinviewer.ground.sections.base import Section, field, known_regions


class RegionKernel(Section):
    kernel_size: float = field(1.0, ge=0.0, le=1000.0,
        label="kernel size",
        tip="per-region kernel size of eq. 12 (ears and nose scatter more)")
    scale_x: float = field(1.0, ge=0.0, le=1000.0,
        label="blur scale",
        tip="per-region blur radius scale (scale_x of eq. 12)")
    scale_y: float = field(0.0, ge=0.0, le=1000.0,
        label="blur offset",
        unit="texels",
        tip="per-region extra blur radius (scale_y of eq. 12), in light-map texels at a 1024² map")


def _default_gosselin_regions() -> dict[str, RegionKernel]:
    # seed 000 after eq. (13): ears and nose scatter more, cheeks less
    ks = {"other": 1.0, "forehead": 1.0, "nose": 1.6, "cheeks": 0.7, "lips": 1.0, "chin": 1.0,
          "ears": 2.0, "neck": 1.2, "scalp": 1.0}
    return {k: RegionKernel(kernel_size=v) for k, v in ks.items()}


class GosselinSettings(Section):
    """Gosselin et al. 2004 (seed 000 §4.1, eq. 8-19)."""
    light_map_size: int = field(1024, ge=256, le=4096,
        label="light map size",
        unit="texels",
        tip="texture-space light map resolution, eq. 8-10. Texture-space cost ~ size^2")
    iterations: int = field(4, ge=0, le=64,
        label="blur passes",
        tip="number of 13-tap Poisson blurs, eq. 11-13 (each adds to the blur radius)")
    # seed 000 eq. (12): radius = size * (kernel_size * scale_x + scale_y), global scales multiply per-region ones;
    # size = 1/1024 (radii are texels at a 1024 map, rescaled to light_map_size: the look is size-independent).
    # 2.0: ~1.2 mm effective sigma after 4 iterations on the default head (0.57 mm/texel at 1024)
    scale_x: float = field(2.0, ge=0.0, le=1000.0,
        label="blur scale",
        tip=("blur radius scale (scale_x of eq. 12: radius = size * (kernel_size * scale_x + scale_y)); "
             "multiplies the per-region scale"))
    scale_y: float = field(0.0, ge=0.0, le=1000.0,
        label="blur offset",
        unit="texels",
        tip=("extra blur radius in light-map texels at a 1024² map (rescaled to the map size): scale_y of eq. "
             "12, added to the per-region one"))
    regions: dict[str, RegionKernel] = Field(default_factory=_default_gosselin_regions)
    radius_mode: Literal["printed", "mm"] = field(
        "printed", description="printed: eq. (12) radii in texels at a 1024 map (region kernels); mm: per-channel "
        "radii in mm from the d'Eon profile's variance (deon.gaussians: iterations x the kernel's second moment "
        "= sum w v / sum w), through the stretch map, so the blur matches the profile at any map size",
        label="radius units",
        tip=("printed: eq. 12's radii in texels at a 1024 map; mm: per-channel radii from the d'Eon profile's "
             "variance, through the stretch map (compares with d'Eon)"))
    specular_shadow: Literal["visibility", "printed"] = field(
        "visibility", description="eq. (18) attenuation: visibility = LUM(blurred)/LUM(unshadowed irradiance) "
        "in [0, 1] (default); printed = LUM(blurred) as printed (scales with Lc^2)",
        label="specular shadow",
        tip="eq. 18 shadow attenuation of the specular: visibility (default) or as printed")

    _regions = field_validator("regions")(known_regions)
