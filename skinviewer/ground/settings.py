"""One typed, validated settings model. Presets are its JSON; the viewer, presets and the CLI's
``--set key=value`` all edit this same object. Passes read only the dotted paths they declare.
"""
from __future__ import annotations

import json
import math
import os
from pathlib import Path
from typing import Any, Literal

from pydantic import (
    BaseModel,
    ConfigDict,
    Field,
    StrictInt,
    ValidationError,
    field_validator,
    model_validator,
)

from skinviewer.ground.constants import MAX_GAUSSIANS, MAX_LIGHTS, MAX_PCF
from skinviewer.ground.constants import REGIONS as REGIONS  # re-exported: passes, scenes and the UI import it from here
from skinviewer.ground.files import FileReadError, atomic_write_text, read_regular_file

SCHEMA_VERSION = 1

Vec3 = tuple[float, float, float]



class _Model(BaseModel):
    model_config = ConfigDict(extra="forbid", validate_assignment=True)


def _known_regions(v: dict[str, Any]) -> dict[str, Any]:
    bad = [k for k in v if k not in REGIONS]
    if bad:
        raise ValueError(f"unknown region(s) {bad}; known: {list(REGIONS)}")
    return v


def _finite(v: float) -> float:
    if not math.isfinite(v):
        raise ValueError("must be a finite number")
    return v


def _finite_vec(v: Vec3 | None) -> Vec3 | None:
    if v is not None and any(not math.isfinite(c) for c in v):
        raise ValueError("components must be finite numbers")
    return v


def _file_path(v: str | None) -> str | None:
    """A path the OS can open: no NUL byte, encodable (a lone surrogate from JSON is not)."""
    if v is None:
        return v
    if "\x00" in v:
        raise ValueError("path contains a NUL byte")
    if not v.strip():
        raise ValueError("path is empty")
    try:
        os.fsencode(v)
        v.encode("utf-8", "surrogateescape")
    except (UnicodeError, ValueError):
        raise ValueError("path is not valid text for this file system (lone surrogate?)") from None
    return v


# a light farther than this (mesh units) is refused: shadow-map projections lose all precision
MAX_POSITION = 1e9


class SceneSettings(_Model):
    name: Literal["head", "laser", "shadow-edge", "backlit-ear", "stretch-plane", "regions-plane"] = "head"
    mesh: str | None = Field(None, description="path of a glTF/GLB/OBJ/PLY mesh; overrides `name`")
    mm_per_unit: float | None = Field(
        None, gt=0, le=1e6, description="millimetres per mesh unit; None: the scene's own (built-ins are in mm)")
    albedo_map: str | None = None
    normal_map: str | None = None
    specular_map: str | None = None
    region_map: str | None = Field(None, description="region-ID PNG: red channel = index in REGIONS")
    head_detail: int = Field(1, ge=0, le=2, description="default head resolution level (0 small, 1 normal, 2 fine)")
    seam_aware: bool = Field(True, description="texture-space gutters near UV seams continue on the island across "
                             "the seam (3D adjacency), so blurs do not read invented values there (issue 10)")
    stretch_metric: Literal["vertex", "triangle"] = Field(
        "vertex", description="the stretch map (seed 000 eq. 27) from the UV->surface metric averaged at the "
        "vertices and interpolated (vertex: smooth where the UVs are not, e.g. slivers; the lowest RMS on the seam "
        "bench) or per triangle, as printed (triangle)")
    back_faces: Literal["auto", "cull", "show"] = Field(
        "auto", description="what the camera sees of back faces. cull: front faces only (a closed surface's "
        "inside is never visible; a back face that wins a depth fight at a thin fold shows a dark speck); show: the "
        "back of the surface too, shaded with the normal reversed (open sheets); auto: cull on a closed mesh, show "
        "on an open one")

    _paths = field_validator("mesh", "albedo_map", "normal_map", "specular_map", "region_map")(_file_path)


class CameraSettings(_Model):
    yaw: float = Field(25.0, ge=-3600, le=3600, description="degrees about +Y")
    pitch: float = Field(5.0, ge=-89.0, le=89.0, description="degrees")
    distance: float | None = Field(None, gt=0, le=1e7, description="in mesh units; None: frame the mesh")
    target: Vec3 | None = Field(None, description="look-at point in mesh units; None: bounds centre")
    fov_y: float = Field(30.0, gt=1.0, lt=170.0, description="degrees")

    _f = field_validator("yaw", "pitch")(_finite)
    _t = field_validator("target")(_finite_vec)


class LightSettings(_Model):
    # beam: a collimated beam of radius beam_radius (mesh units) along -direction through position
    # (the laser of GPU Gems 3 §14.4.1)
    # environment: an HDR image around the scene (issue 32; the fields below the shadow flag)
    kind: Literal["directional", "point", "beam", "environment"] = "directional"
    color: Vec3 = (1.0, 1.0, 1.0)
    intensity: float = Field(3.0, ge=0.0, le=1e6)
    # directional: direction the light travels *from* (towards the light); point: position in mesh units
    direction: Vec3 = (0.4, 0.5, 1.0)
    position: Vec3 = (0.0, 0.0, 400.0)
    beam_radius: float = Field(0.05, gt=0.0, le=1e6)
    cast_shadow: bool = True
    enabled: bool = True
    environment: str = Field(
        "studio", description="kind environment: a built-in (studio, overcast, window) or the path of a Radiance "
        ".hdr / OpenEXR .exr of linear radiance (notes/envlight.md)")
    layout: Literal["auto", "equirect", "cross"] = Field(
        "auto", description="the file's layout: equirect (2:1), cube cross (4:3 / 3:4), auto from the aspect")
    yaw: float = Field(0.0, ge=-3600, le=3600, description="degrees the environment is turned about +y")
    sh_order: int = Field(2, ge=0, le=2, description="spherical-harmonic order of the environment's diffuse "
                          "irradiance (Ramamoorthi & Hanrahan 2001; 2: 9 coefficients)")
    occlusion: bool = Field(True, description="the environment's light is occluded by the mesh: per-vertex "
                            "SH transfer vectors baked with Embree, and specular occlusion")
    ao_rays: int = Field(256, ge=4, le=4096, description="rays per vertex of the visibility bake (SH transfer "
                         "vectors and ambient occlusion; stratified, cosine-weighted; once per mesh, cached)")
    transfer_order: int = Field(4, ge=0, le=4, description="SH bands of the per-vertex transfer vectors that shadow "
                                "the environment's diffuse light (Sloan et al. 2002; 4: 25 coefficients, 2: 9); "
                                "0: ambient occlusion x SH irradiance at the bent normal")

    _env_path = field_validator("environment")(_file_path)

    @field_validator("color")
    @classmethod
    def _color(cls, v: Vec3) -> Vec3:
        if any((not math.isfinite(c)) or c < 0 for c in v):
            raise ValueError("colour components must be finite and >= 0")
        return v

    @field_validator("direction")
    @classmethod
    def _dir(cls, v: Vec3) -> Vec3:
        if any(not math.isfinite(c) for c in v) or sum(c * c for c in v) < 1e-12:
            raise ValueError("direction must be a finite, non-zero vector")
        return v

    @field_validator("position")
    @classmethod
    def _pos(cls, v: Vec3) -> Vec3:
        if any(not math.isfinite(c) for c in v):
            raise ValueError("position must be finite")
        if max(abs(c) for c in v) > MAX_POSITION:
            raise ValueError(f"position must be within +-{MAX_POSITION:g} mesh units")
        return v


class ShadowSettings(_Model):
    map_size: int = Field(1024, ge=64, le=8192)
    map_size_mode: Literal["fixed", "auto"] = Field(
        "fixed", description="auto: shadow maps sized from the scene's screen coverage, map_size at most (issue 14)")
    # seed 000 eq. (7): shadowed if d(P) - ds > tol; tol in normalised light-space depth
    tol: float = Field(0.002, ge=0.0, le=0.5)
    pcf: int = Field(1, ge=0, le=MAX_PCF, description="percentage-closer filter radius in texels (0 = eq. 7 hard test)")
    pcf_filter: Literal["bilinear", "box"] = Field(
        "bilinear", description="bilinear: the PCF box slides with the lookup's sub-texel position, so shadow edges "
        "have no one-texel terraces (16 instead of 9 taps at pcf 1; closer to the ground truth); box: snapped to texels")


class RenderSettings(_Model):
    width: int = Field(640, ge=16, le=8192)
    height: int = Field(640, ge=16, le=8192)
    exposure: float = Field(0.9, gt=0.0, le=1e4)
    tone_map: Literal["filmic", "linear"] = Field(
        "filmic", description="display transform after exposure: filmic (ACES fit, soft highlight roll-off) or "
        "linear (clamp; what measurements compare)")
    background: Vec3 = (0.05, 0.05, 0.06)
    background_environment: Literal["off", "sharp", "blurred"] = Field(
        "off", description="with an environment light: the background shows the environment seen from the camera "
        "(sharp, or blurred as the pre-filtered m = 0.15 level), exposed and tone-mapped like the skin; off: the "
        "background colour")
    check_finite: bool = Field(
        True, description="after a pass runs, check its outputs for NaN/Inf (a small GPU reduction); "
        "the frame report names a pass whose output is not finite")
    timing: Literal["auto", "sync", "gpu"] = Field(
        "auto", description="auto: GL timer queries on a hardware GPU (no glFinish between passes), sync on a "
        "software rasterizer (llvmpipe: its timer queries are far too low); sync: glFinish + wall clock per "
        "pass; gpu: GL timer queries")
    texel_surface: bool = Field(
        True, description="texture-space techniques (d'Eon's irradiance and transmitted light, Gosselin's light "
                          "map) shade once per texel from the texel surface map (the mesh's attributes per "
                          "texel, rasterised once per mesh and size) instead of rasterising the mesh's small "
                          "triangles each time (issue 14; the same values up to float rounding)")
    mesh_lod: Literal["auto", "full"] = Field(
        "auto", description="auto: draw a coarser copy of the mesh (1/4 of the triangles per level) when the "
        "head is so small on screen that its triangles are far under a pixel; full: always the whole mesh")
    governor: Literal["off", "interactive", "fixed-budget"] = Field(
        "interactive", description="the viewer's quality governor (issue 27; `render`/`bench` ignore it): "
        "interactive: while you drag or edit, the most accurate preview of the technique's own knobs that fits "
        "governor_budget_ms on this machine (skinviewer calibrate), refined up to your settings when input "
        "stops; fixed-budget: that preview always; off: every frame at your settings")
    governor_budget_ms: float = Field(
        100.0, ge=-1e6, le=1e6, description="the interaction budget (ms a frame) the governor's preview must fit; "
        "<= 0 or one nothing fits: the cheapest preview, said in the status bar")

    _bg = field_validator("background")(_finite_vec)

    @field_validator("background_environment", mode="before")
    @classmethod
    def _bg_env(cls, v: Any) -> Any:
        # --set reads off / on as false / true
        return {False: "off", True: "sharp"}.get(v, v) if isinstance(v, bool) else v

    @field_validator("governor", mode="before")
    @classmethod
    def _governor_off(cls, v: Any) -> Any:
        # --set render.governor=off reads "off" as false (on: the default, interactive)
        return {False: "off", True: "interactive"}.get(v, v) if isinstance(v, bool) else v


class PhongSettings(_Model):
    ambient: float = Field(0.03, ge=0.0, le=10.0)
    specular: float = Field(0.25, ge=0.0, le=100.0)
    shininess: float = Field(32.0, ge=1.0, le=4096.0)


class RegionSpecular(_Model):
    m: float | None = Field(None, ge=0.0, le=1.0)
    rho_s: float | None = Field(None, ge=0.0, le=10.0)


def _default_region_specular() -> dict[str, RegionSpecular]:
    # seed 002 §14.3: Weyrich et al. 2006 measured m and rho_s per facial region; the pattern they found
    # (nose and lips shinier, cheeks and chin rougher) with values inside their measured range
    table = {"forehead": (0.32, 0.20), "nose": (0.28, 0.24), "lips": (0.30, 0.22), "cheeks": (0.38, 0.15),
             "chin": (0.35, 0.17)}
    return {k: RegionSpecular(m=m, rho_s=r) for k, (m, r) in table.items()}


class SpecularSettings(_Model):
    """Kelemen/Szirmay-Kalos (seed 000 eq. 14-16, seed 002 §14.3)."""
    m: float = Field(0.3, ge=0.0, le=1.0, description="Beckmann roughness")
    f0: float = Field(0.028, ge=0.0, le=1.0, description="Fresnel reflectance at normal incidence")
    rho_s: float = Field(0.18, ge=0.0, le=10.0, description="specular intensity")
    mode: Literal["direct", "beckmann_lut"] = "direct"
    lut_size: int = Field(512, ge=16, le=4096)
    per_region: dict[str, RegionSpecular] = Field(default_factory=lambda: _default_region_specular())

    _regions = field_validator("per_region")(_known_regions)


class RegionKernel(_Model):
    kernel_size: float = Field(1.0, ge=0.0, le=1000.0)
    scale_x: float = Field(1.0, ge=0.0, le=1000.0)
    scale_y: float = Field(0.0, ge=0.0, le=1000.0)


def _default_gosselin_regions() -> dict[str, RegionKernel]:
    # seed 000 after eq. (13): ears and nose scatter more, cheeks less
    ks = {"other": 1.0, "forehead": 1.0, "nose": 1.6, "cheeks": 0.7, "lips": 1.0, "chin": 1.0,
          "ears": 2.0, "neck": 1.2, "scalp": 1.0}
    return {k: RegionKernel(kernel_size=v) for k, v in ks.items()}


class GosselinSettings(_Model):
    """Gosselin et al. 2004 (seed 000 §4.1, eq. 8-19)."""
    light_map_size: int = Field(1024, ge=256, le=4096)
    iterations: int = Field(4, ge=0, le=64)
    # seed 000 eq. (12): radius = size * (kernel_size * scale_x + scale_y), global scales multiply per-region ones;
    # size = 1/1024 (radii are texels at a 1024 map, rescaled to light_map_size: the look is size-independent).
    # 2.0: ~1.2 mm effective sigma after 4 iterations on the default head (0.57 mm/texel at 1024)
    scale_x: float = Field(2.0, ge=0.0, le=1000.0)
    scale_y: float = Field(0.0, ge=0.0, le=1000.0)
    regions: dict[str, RegionKernel] = Field(default_factory=_default_gosselin_regions)
    radius_mode: Literal["printed", "mm"] = Field(
        "printed", description="printed: eq. (12) radii in texels at a 1024 map (region kernels); mm: per-channel "
        "radii in mm from the d'Eon profile's variance (deon.gaussians: iterations x the kernel's second moment "
        "= sum w v / sum w), through the stretch map, so the blur matches the profile at any map size")
    specular_shadow: Literal["visibility", "printed"] = Field(
        "visibility", description="eq. (18) attenuation: visibility = LUM(blurred)/LUM(unshadowed irradiance) "
        "in [0, 1] (default); printed = LUM(blurred) as printed (scales with Lc^2)")

    _regions = field_validator("regions")(_known_regions)


class Gaussian(_Model):
    variance: float = Field(..., ge=0.0, le=1e4, description="mm^2")
    weights: Vec3 = Field(..., description="RGB weights")

    @field_validator("weights")
    @classmethod
    def _w(cls, v: Vec3) -> Vec3:
        if any((not math.isfinite(c)) or c < 0 for c in v):
            raise ValueError("weights must be finite and >= 0")
        return v


def _default_gaussians() -> list[Gaussian]:
    # d'Eon & Luebke 2007 six-Gaussian skin profile (seed 000 Tabela 2, seed 002, ../shared/reference)
    table = [(0.0064, (0.233, 0.455, 0.649)), (0.0484, (0.100, 0.336, 0.344)), (0.187, (0.118, 0.198, 0.0)),
             (0.567, (0.113, 0.007, 0.007)), (1.99, (0.358, 0.004, 0.0)), (7.41, (0.078, 0.0, 0.0))]
    return [Gaussian(variance=v, weights=w) for v, w in table]


class DeonSettings(_Model):
    """d'Eon & Luebke 2007 (seed 000 §4.2, eq. 20-35; seed 002 §14.4)."""
    # variances need not ascend (the blur chain clamps a negative increment to 0) and weights need not
    # sum to 1: profile_warnings() says so, never an error
    gaussians: list[Gaussian] = Field(default_factory=_default_gaussians, min_length=1, max_length=MAX_GAUSSIANS)
    mix: float = Field(0.5, ge=0.0, le=1.0, description="pre/post-scatter texturing, eq. (28), (34)")
    stretch: bool = True
    stretch_per_gaussian: bool = False
    stretch_shear: bool = Field(True, description="blur along the full UV->surface Jacobian (the second pass follows "
                                "the texels' shear, covariance sigma^2 (J^T J)^-1) instead of eq. 27's per-axis lengths "
                                "(issue 10 item 2: exact on sheared planes; on the scan red p99 lower over four "
                                "lights, notes/fidelity.md)")
    tsm: bool = True
    tsm_size: int = Field(1024, ge=64, le=8192)
    tsm_light: int | None = Field(
        1, ge=0, le=MAX_LIGHTS - 1, description="light the TSM is rendered from (None: the first shadow-casting light)")
    tsm_form: Literal["exact", "printed"] = Field(
        "exact", description="exact: exp(-d^2/(2 v_i)); printed: exp(-d^2/v_i) as in seed 000 eq. (33)")
    tsm_gather: int = Field(
        16, ge=0, le=64,
        description="light-space samples per Gaussian wider than two TSM texels: the lit surfaces around the light "
                    "ray are integrated, each sample at its own 3D distance, instead of eq. (33)'s one lit point on "
                    "the ray, so an ear's folds lit from behind glow as in the ground truth (0: eq. 33 on the ray; "
                    "issue 10 item 4, notes/fidelity.md)")
    energy_conservation: bool = True
    irradiance_size: int = Field(1024, ge=256, le=4096)
    irradiance_size_mode: Literal["fixed", "auto"] = Field(
        "fixed", description="auto: the irradiance map (and its blurs) sized from the head's screen coverage, "
                             "irradiance_size at most, with hysteresis (issue 14)")
    fold_below_texels: float = Field(
        1.0, ge=0.0, le=8.0,
        description="a later blur whose sigma increment is under this many (mean) texels is folded: blur_i = "
                    "blur_(i-1), the next blur adds its variance exactly (0: off). 1 by the truth bench: lower "
                    "RMS, p99 and DSSIM than 0 at 256-1024^2 maps, and fewer blurs (notes/perf.md)")
    surface_gather_below_texels: float = Field(
        2.0, ge=0.0, le=3.0,
        description="a blur step whose sigma is at most this many (mean) texels is a direct sum over the surface "
                    "with 3D distances (eq. 21 at texel resolution: the texels around it, then 2 x 2 blocks out to 12 "
                    "texels) instead of separable taps that assume the surface flat and the stretch constant over "
                    "the kernel: closer to the truth where the atlas is coarse or uneven, ~130 ms more per step and "
                    "light change at 512^2 on llvmpipe (0: every step separable; 3: also the next, wider step; "
                    "issue 10 item 1, notes/fidelity.md)")
    skip_gutters: bool = Field(
        True, description="blurs shade only the tiles of the UV islands (and the ring a reader reaches); with the "
                          "seam fill, the fill dilates the gutters (images identical; the summed step -14 to -18 % "
                          "at 1024^2 on llvmpipe, issue 27, notes/perf.md)")
    tsm_auto: bool = Field(
        True, description="skip the TSM when no light is behind a part thin enough to transmit that is in view")
    subpixel_kernel_px: float = Field(
        0.3, ge=0.0, le=4.0,
        description="when the widest Gaussian's sigma spans under this many pixels on screen, diffusion cannot "
                    "show: blurs, stretch and TSM are skipped and the final pass reads the irradiance (0: never)")
    combine_blurs: bool = Field(
        True, description="sum the weighted blurs (eq. 34) once in texture space, so a camera move reads one "
                          "texture instead of one per Gaussian (issue 14; equal up to float rounding)")
    specular_shadows: Literal["texture", "pixel"] = Field(
        "texture", description="where the specular's shadow test (eq. 10) is evaluated: texture: once per texel "
        "by the irradiance pass (the same PCF, kept per light), so a camera move does no shadow-map lookups; "
        "pixel: per pixel in the final pass")
    reuse_irradiance_below_texels: float = Field(
        0.5, ge=0.0, le=8.0,
        description="blur 1 reuses the irradiance itself when its sigma is under this many (mean) texels: "
                    "a sub-texel 7-tap blur changes nothing")
    texel_samples: Literal[1, 4] = Field(
        1, description="irradiance samples per texel: 4 averages the shadow test and N.L over a rotated 2 x 2 "
                       "grid of the texel's surface patch, so a texel a shadow edge crosses carries its lit "
                       "fraction (issue 30 item 4; 4x the shadow lookups of the irradiance pass, 2.3-2.7x its time; "
                       "against the ground truth no gain on the head or the scan: notes/truth.md)")
    open_border: Literal["reflect", "absorb"] = Field(
        "reflect", description="past an open mesh border (with scene.seam_aware): reflect: each blur after the first "
        "reads the odd reflection of the light about the border, so the light earlier steps carried past it comes "
        "back as in one blur of E over the surface (issue 30 item 5); absorb: no light there before every step "
        "(loses light at the rim)")


class BurleySettings(_Model):
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
    transmission: Literal["closed-form", "thick", "jimenez2010"] = Field(
        "closed-form", description="through thin parts, from the shadow-map thickness t (spec §5.4, HDRP): closed-form "
        "T(t) = (e^(-S t) + 3 e^(-S t/3)) / 4, the Burley profile integrated over the plane at depth t (thin mode); "
        "thick: e^(-S t/3) (HDRP's regular mode, no baked thickness); jimenez2010: the Gaussian T(d) of the "
        "`transmittance` section")

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


class PennerSettings(_Model):
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


class Burley2Settings(_Model):
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


class ScreenSettings(_Model):
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


class TransmittanceSettings(_Model):
    """Jimenez et al. 2010 translucency from shadow-map thickness (seed 001 §3.5, eq. 3.14-3.18; spec §6):
    added to the diffuse irradiance of every screen-space technique before its blur."""
    enabled: bool = True
    translucency: float = Field(
        0.83, ge=0.0, le=0.999, description="[SEP] translucency: profile distance = 2.75 (1 - t) x thickness (mm)")
    form: Literal["printed", "exact"] = Field(
        "printed", description="printed: exp(-d^2/v_i) (eq. 3.18, [SEP]); exact: exp(-d^2/(2 v_i))")
    wrap: float = Field(0.0, ge=0.0, le=1.0, description="T(d) x saturate(wrap + L.(-N)): 0 = eq. 3.15; [SEP] uses 0.3 "
                        "(a wrap-lighting glow along the terminator)")


def _odd(v: int) -> int:
    if v % 2 == 0:
        raise ValueError("must be odd (a centre tap)")
    return v


class SsssSettings(_Model):
    """Jimenez et al. 2009 screen-space Gaussians (seed 001 §3.2, eq. 3.2; spec §3): one separable blur per
    Gaussian of ``deon.gaussians``, incremental, width s = alpha / (d + beta |grad d|)."""
    alpha: float = Field(11.0, gt=0.0, le=1000.0, description="global SSS level (eq. 3.2); 11 = the true projection")
    beta: float = Field(800.0, ge=0.0, le=1e5, description="how strongly the depth gradient shrinks the kernel (eq. 3.2)")
    taps: int = Field(7, ge=3, le=63, description="taps per 1-D pass over +-3 sigma (7: d'Eon's kernel)")
    gaussians: int = Field(8, ge=1, le=8, description="blur at most this many Gaussians (the rest: a 1-Gaussian refit is "
                                                       "not done; their weight goes to the widest one kept)")

    _odd_taps = field_validator("taps")(_odd)


class SeparableSettings(_Model):
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

    _odd_taps = field_validator("taps")(_odd)

    @field_validator("strength", "falloff")
    @classmethod
    def _unit(cls, v: Vec3) -> Vec3:
        if any((not math.isfinite(c)) or c < 0 or c > 10 for c in v):
            raise ValueError("components must be finite and in [0, 10]")
        return v


class LookSettings(_Model):
    """The artist model (physics/artist.py): scatter colour and radius per channel, Burley's surface albedo
    and (diffuse) mean free path as Unreal's Burley profile and HDRP present them (seed 001 eq. 2.84, 2.88).
    With source = look they drive deon.gaussians (d'Eon, ssss, penner, Gosselin in mm mode) and
    burley.albedo / burley.mfp (burley, burley2); the raw tables stay editable under Advanced."""
    source: Literal["table", "look"] = Field(
        "table", description="look: the scatter colour and radius below set each technique's profile; table: the "
        "techniques' own tables (deon.gaussians, burley.albedo/mfp) as they are, the look only shown as an estimate")
    scatter_color: Vec3 = Field(
        (0.436, 0.227, 0.131), description="surface albedo A per channel: the profile's total diffuse reflectance "
        "(eq. 2.84) and its shape s(A) (eq. 2.88)")
    scatter_radius: Vec3 = Field(
        (1.574, 0.364, 0.244), description="mean free path per channel, mm (Unreal: mean free path colour x distance): "
        "the profile's scale d = radius / s(A), its mean radius 2.5 d (default: d'Eon's table)")
    gaussians: int = Field(6, ge=2, le=MAX_GAUSSIANS, description="Gaussians of the fitted table (d'Eon, ssss, penner)")
    energy: Literal["albedo-map", "profile"] = Field(
        "albedo-map", description="albedo-map: the table's weights sum to 1 per channel (d'Eon's convention: the "
        "colour is in the albedo map); profile: they sum to the scatter colour (the profile tints the skin)")

    @field_validator("scatter_color")
    @classmethod
    def _color(cls, v: Vec3) -> Vec3:
        if any((not math.isfinite(c)) or c < 0 or c > 1 for c in v):
            raise ValueError("scatter colour components must be in [0, 1]")
        return v

    @field_validator("scatter_radius")
    @classmethod
    def _radius(cls, v: Vec3) -> Vec3:
        if any((not math.isfinite(c)) or c < 0.01 or c > 50 for c in v):
            raise ValueError("scatter radius components must be in [0.01, 50] mm")
        return v


def three_light_rig() -> list[LightSettings]:
    """The default rig before issue 32 (presets/studio-three-lights.json): a warm key high on the left
    of the face, a cool rim behind the right ear (deon.tsm_light = 1: it makes the ears glow), a soft
    unshadowed fill from the camera side."""
    return [LightSettings(direction=(-0.45, 0.55, 0.75), intensity=1.8, color=(1.0, 0.95, 0.88)),
            LightSettings(direction=(0.55, 0.35, -0.9), intensity=1.6, color=(0.9, 0.93, 1.0)),
            LightSettings(direction=(0.9, 0.05, 0.45), intensity=0.3, color=(0.85, 0.9, 1.0), cast_shadow=False)]


def default_rig() -> list[LightSettings]:
    """The default lights (issue 32): the warm key of the three-light rig and the built-in studio
    environment (two soft boxes, occluded by the mesh), as presets/studio-environment.json, with both
    intensities scaled by 0.61 so that the default exposure 0.9 is the one the scene's luminance calls
    for (passes/environment.exposure_from_luminance; the preset's own exposure is 0.55 at 1.2 / 1.0).
    The key is light 0, so deon.tsm_light = 1 (the environment) falls back to it."""
    return [LightSettings(direction=(-0.45, 0.55, 0.75), intensity=0.73, color=(1.0, 0.95, 0.88)),
            LightSettings(kind="environment", environment="studio", intensity=0.61, cast_shadow=False)]


class Settings(_Model):
    schema_version: StrictInt = SCHEMA_VERSION  # strict: JSON `true` is not version 1
    technique: Literal["phong", "gosselin", "deon", "ssss", "separable", "burley", "burley2", "penner"] = "deon"
    scene: SceneSettings = Field(default_factory=SceneSettings)
    camera: CameraSettings = Field(default_factory=CameraSettings)
    render: RenderSettings = Field(default_factory=RenderSettings)
    lights: list[LightSettings] = Field(
        default_factory=lambda: default_rig(),
        min_length=1, max_length=MAX_LIGHTS)
    shadow: ShadowSettings = Field(default_factory=ShadowSettings)
    phong: PhongSettings = Field(default_factory=PhongSettings)
    specular: SpecularSettings = Field(default_factory=SpecularSettings)
    gosselin: GosselinSettings = Field(default_factory=GosselinSettings)
    deon: DeonSettings = Field(default_factory=DeonSettings)
    screen: ScreenSettings = Field(default_factory=ScreenSettings)
    transmittance: TransmittanceSettings = Field(default_factory=TransmittanceSettings)
    ssss: SsssSettings = Field(default_factory=SsssSettings)
    separable: SeparableSettings = Field(default_factory=SeparableSettings)
    burley: BurleySettings = Field(default_factory=BurleySettings)
    burley2: Burley2Settings = Field(default_factory=Burley2Settings)
    penner: PennerSettings = Field(default_factory=PennerSettings)
    look: LookSettings = Field(default_factory=LookSettings)

    @model_validator(mode="after")
    def _version(self) -> Settings:
        if self.schema_version != SCHEMA_VERSION:
            raise ValueError(f"schema_version {self.schema_version} is not supported (this build reads {SCHEMA_VERSION})")
        return self


# ---------------------------------------------------------------------------------------------
# errors, paths, presets

class SettingsError(ValueError):
    """Invalid settings: ``errors`` lists (path, message), one per invalid field."""

    def __init__(self, errors: list[tuple[str, str]], source: str = ""):
        self.errors = errors
        self.source = source
        head = f"{source}: " if source else ""
        super().__init__(head + "; ".join(f"{p}: {m}" for p, m in errors))


def _errors_of(exc: ValidationError) -> list[tuple[str, str]]:
    out = []
    for e in exc.errors():
        path = ".".join(str(p) for p in e["loc"]) or "<root>"
        msg = e["msg"]
        if msg.startswith("Value error, "):
            msg = msg[len("Value error, "):]
        out.append((path, msg))
    return out


def validate(data: Any, source: str = "") -> Settings:
    try:
        return Settings.model_validate(data)
    except ValidationError as exc:
        raise SettingsError(_errors_of(exc), source) from None


def to_dict(s: Settings) -> dict[str, Any]:
    return s.model_dump(mode="json")


def get_path(obj: Any, path: str) -> Any:
    """Value at a dotted path (``lights.0.intensity``) in a settings object or a plain dict/list."""
    cur = obj
    if not path:
        return cur
    for part in path.split("."):
        if part == "#":  # "lights.#": the length of a list
            cur = len(cur)
        elif isinstance(cur, (list, tuple)):
            cur = cur[_index(part)]
        elif isinstance(cur, dict):
            cur = cur[part]
        else:
            if part not in type(cur).model_fields:
                raise KeyError(path)
            cur = getattr(cur, part)
    return cur


def _index(part: str) -> int:
    """A list index in a dotted path: plain decimal digits only (``lights.-1`` is not the last light)."""
    if not (part.isascii() and part.isdigit()) or len(part) > 6:
        raise IndexError(part)
    return int(part)


def _jsonable(v: Any) -> Any:
    if isinstance(v, BaseModel):
        return v.model_dump(mode="json")
    if isinstance(v, (list, tuple)):
        return [_jsonable(x) for x in v]
    if isinstance(v, dict):
        return {k: _jsonable(x) for k, x in v.items()}
    return v


def value_key(s: Settings, path: str) -> str:
    """A stable text key of the value at ``path`` (used by the pass graph's cache)."""
    return json.dumps(_jsonable(get_path(s, path)), sort_keys=True)


def parse_value(text: str) -> Any:
    """A ``--set`` value: JSON when it parses (numbers, true/false, null, lists), else the bare string."""
    try:
        return json.loads(text)
    except (ValueError, RecursionError) as exc:
        if not isinstance(exc, json.JSONDecodeError):  # 5,000-digit integers, 100,000 nested lists
            raise SettingsError([("<value>", _json_problem(exc))]) from None
        lowered = text.strip().lower()
        if lowered in ("on", "yes"):
            return True
        if lowered in ("off", "no"):
            return False
        if "," in text:  # 1,2,3 -> [1, 2, 3]
            try:
                return [json.loads(p) for p in text.split(",")]
            except (ValueError, RecursionError):
                pass
        return text


def with_values(s: Settings, assignments: dict[str, Any]) -> Settings:
    """A new validated Settings with dotted-path assignments applied; SettingsError names bad paths."""
    data = to_dict(s)
    errors = []
    for path, value in assignments.items():
        parts = path.split(".")
        cur: Any = data
        try:
            for p in parts[:-1]:
                cur = cur[_index(p)] if isinstance(cur, list) else cur[p]
            last = parts[-1]
            if isinstance(cur, list):
                idx = _index(last)
                if idx == len(cur):
                    cur.append(value)
                else:
                    cur[idx] = value
            elif isinstance(cur, dict):
                # dict-valued fields (per-region tables) accept new keys; models do not
                if last not in cur and not _is_free_dict(parts[:-1]):
                    raise KeyError(last)
                cur[last] = value
            else:
                raise KeyError(last)
        except (KeyError, IndexError, ValueError, TypeError):
            errors.append((path, "no such setting" + _did_you_mean(data, parts)))
    if errors:
        raise SettingsError(errors)
    return validate(data)


def _did_you_mean(data: Any, parts: list[str]) -> str:
    """'; did you mean lights.0.intensity?' for a mistyped dotted path (the closest key where it goes wrong)."""
    import difflib
    cur = data
    done: list[str] = []
    for p in parts:
        if isinstance(cur, dict) and p in cur:
            cur, done = cur[p], done + [p]
        elif isinstance(cur, list) and p.isdigit() and int(p) < len(cur):
            cur, done = cur[int(p)], done + [p]
        elif isinstance(cur, dict):
            close = difflib.get_close_matches(p, list(cur), n=1, cutoff=0.6)
            if not close:
                return ""
            rest = parts[len(done) + 1:]
            return f"; did you mean {'.'.join(done + close + rest)}?"
        else:
            return ""
    return ""


def _is_free_dict(parent: list[str]) -> bool:
    return bool(parent) and parent[-1] in ("per_region", "regions")


def parse_assignments(items: list[str]) -> dict[str, Any]:
    out: dict[str, Any] = {}
    errors = []
    for item in items:
        if "=" not in item:
            errors.append((item, "expected key=value"))
            continue
        k, v = item.split("=", 1)
        try:
            out[k.strip()] = parse_value(v.strip())
        except SettingsError as exc:
            errors += [(k.strip(), m) for _, m in exc.errors]
    if errors:
        raise SettingsError(errors)
    return out


# a preset is a small JSON file: anything larger is not one (and /dev/zero never ends)
MAX_PRESET_BYTES = 4 * 1024 * 1024
# scene fields holding file paths: relative ones in a preset are relative to the preset's folder
PATH_FIELDS = ("mesh", "albedo_map", "normal_map", "specular_map", "region_map")


def _json_problem(exc: BaseException) -> str:
    if isinstance(exc, RecursionError):
        return "nested too deeply"
    if isinstance(exc, UnicodeDecodeError):
        return f"not UTF-8 text (byte 0x{exc.object[exc.start]:02x} at offset {exc.start})"
    if isinstance(exc, json.JSONDecodeError):
        return f"line {exc.lineno} column {exc.colno}: {exc.msg}"
    return str(exc).split(";")[0]  # e.g. "Exceeds the limit (4300 digits) for integer string conversion"


def load_preset(path: str | os.PathLike[str], base: Settings | None = None) -> Settings:
    """Read a preset. A preset may be partial: its fields override ``base`` (default: defaults).
    Relative scene paths in it are resolved against the preset's folder."""
    p = Path(path)
    try:
        raw = read_regular_file(p, MAX_PRESET_BYTES, what="preset")
    except FileReadError as exc:
        raise SettingsError([("<file>", str(exc))], _shown(p)) from None
    if raw[:2] in (b"\xff\xfe", b"\xfe\xff"):
        raise SettingsError([("<file>", "UTF-16 text: save the preset as UTF-8")], _shown(p))
    try:
        text = raw.decode("utf-8")
        if text.startswith("\ufeff"):
            text = text[1:]  # a UTF-8 byte-order mark
        data = json.loads(text)
    except (ValueError, RecursionError) as exc:  # UnicodeDecodeError and JSONDecodeError are ValueErrors
        where = "<json>" if isinstance(exc, json.JSONDecodeError) or not isinstance(exc, UnicodeDecodeError) \
            else "<file>"
        raise SettingsError([(where, _json_problem(exc))], _shown(p)) from None
    if not isinstance(data, dict):
        raise SettingsError([("<root>", "a preset is a JSON object")], _shown(p))
    if "schema_version" not in data:
        raise SettingsError([("schema_version", "missing")], _shown(p))
    scene = data.get("scene")
    if isinstance(scene, dict):
        data = dict(data, scene={k: _resolve_against(v, p.parent) if k in PATH_FIELDS else v
                                 for k, v in scene.items()})
    try:
        merged = _deep_merge(to_dict(base or Settings()), data)
        return validate(merged, _shown(p))
    except RecursionError:
        raise SettingsError([("<json>", "nested too deeply")], _shown(p)) from None


def _shown(p: Path) -> str:
    """A path as printable text (a lone surrogate in it must not break the error line)."""
    return str(p).encode("utf-8", "backslashreplace").decode("utf-8")


def _resolve_against(v: Any, folder: Path) -> Any:
    if not isinstance(v, str) or not v or "\x00" in v:
        return v  # validation says what is wrong with it
    try:
        if os.path.isabs(v):
            return v
        return os.path.normpath(os.path.join(os.path.abspath(folder), v))
    except (ValueError, UnicodeError):
        return v


def _relative_to(v: str | None, folder: Path) -> str | None:
    if not v:
        return v
    try:
        return os.path.relpath(os.path.abspath(v), os.path.abspath(folder))
    except ValueError:  # another drive (Windows)
        return v


def _deep_merge(base: dict[str, Any], over: dict[str, Any]) -> dict[str, Any]:
    out = dict(base)
    for k, v in over.items():
        if isinstance(v, dict) and isinstance(out.get(k), dict) and k not in ("regions", "per_region"):
            out[k] = _deep_merge(out[k], v)
        else:
            out[k] = v
    return out


def save_preset(s: Settings, path: str | os.PathLike[str], data: dict[str, Any] | None = None) -> None:
    """Write ``s`` (or ``data``, a dict of it such as the viewer's trimmed payload) atomically; scene
    paths are written relative to the preset's folder."""
    data = to_dict(s) if data is None else dict(data)
    folder = Path(path).parent
    if "scene" in data:
        data["scene"] = {k: _relative_to(v, folder) if k in PATH_FIELDS else v for k, v in data["scene"].items()}
    atomic_write_text(path, json.dumps(data, indent=2) + "\n")


def profile_warnings(d: DeonSettings) -> list[str]:
    """Non-fatal problems of a Gaussian table (seed 000 eq. 21): order and per-channel energy."""
    out = []
    vs = [g.variance for g in d.gaussians]
    if any(b <= a for a, b in zip(vs, vs[1:])):
        out.append("variances are not strictly ascending: the hierarchical blur clamps v_i - v_(i-1) to 0")
    if any(v <= 0 for v in vs):
        out.append("a variance is 0: that Gaussian is the irradiance itself")
    for c, name in enumerate("RGB"):
        total = sum(g.weights[c] for g in d.gaussians)
        if abs(total - 1.0) > 0.02:
            verb = "gains" if total > 1 else "loses"
            out.append(f"channel {name} weights sum to {total:.3f}: the profile {verb} energy")
    return out
