"""d'Eon & Luebke 2007's section (seed 000 §4.2, eq. 20-35): the sum-of-Gaussians profile and the texture-space diffusion; ssss and penner read its Gaussians too."""
from __future__ import annotations

import math
from typing import Literal

from pydantic import Field, field_validator

from skinviewer.ground.constants import MAX_GAUSSIANS, MAX_LIGHTS
from skinviewer.ground.sections.base import Section, Vec3, field


class Gaussian(Section):
    variance: float = field(..., ge=0.0, le=1e4, description="mm^2",
        unit="mm²",
        tip=("variance v_i of Gaussian i (mm²), seed 000 eq. 20: G(v, r) = exp(-r²/2v) / (2 pi v). Blurs are "
             "incremental: v_i - v_(i-1), eq. 24"))
    weights: Vec3 = field(..., description="RGB weights",
        unit="RGB",
        tip=("weights w_i of R(r) = sum_i w_i G(v_i, r), seed 000 eq. 21; each channel's weights should sum to"
             " 1 (energy)"))

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


class DeonSettings(Section):
    """d'Eon & Luebke 2007 (seed 000 §4.2, eq. 20-35; seed 002 §14.4)."""
    # variances need not ascend (the blur chain clamps a negative increment to 0) and weights need not
    # sum to 1: profile_warnings() says so, never an error
    gaussians: list[Gaussian] = Field(default_factory=_default_gaussians, min_length=1, max_length=MAX_GAUSSIANS)
    mix: float = field(0.5, ge=0.0, le=1.0, description="pre/post-scatter texturing, eq. (28), (34)",
        label="colour before blur",
        tip=("how much of the skin colour is applied before the blur (pre-scatter texturing): albedo^mix "
             "before, albedo^(1-mix) after, eq. 28 and 34. 0: sharp colour detail, 1: blurred"))
    stretch: bool = field(True,
        label="stretch correction",
        tip="stretch-corrected blur radii from the UV stretch map (eq. 27, used in eq. 25)")
    stretch_per_gaussian: bool = field(False,
        label="stretch per Gaussian",
        tip="a stretch map per Gaussian width instead of one (eq. 25-27)")
    stretch_shear: bool = field(True, description="blur along the full UV->surface Jacobian (the second pass follows "
                                "the texels' shear, covariance sigma^2 (J^T J)^-1) instead of eq. 27's per-axis lengths "
                                "(issue 10 item 2: exact on sheared planes; on the scan red p99 lower over four "
                                "lights, notes/fidelity.md)",
        label="stretch with shear",
        tip=("the blur follows the full UV->surface Jacobian: the second pass runs along the texels' shear, so"
             " a skewed parametrisation blurs round (eq. 27 keeps lengths only)"))
    tsm: bool = field(True,
        label="translucency (TSM)",
        tip="translucent shadow map: light through thin parts (ears), eq. 32-33")
    tsm_size: int = field(1024, ge=64, le=8192,
        label="translucency map",
        unit="texels",
        tip="translucent shadow map (TSM) resolution, eq. 32. Texture-space cost")
    tsm_light: int | None = field(
        1, ge=0, le=MAX_LIGHTS - 1, description="light the TSM is rendered from (None: the first shadow-casting light)",
        label="translucency light")
    tsm_form: Literal["exact", "printed"] = field(
        "exact", description="exact: exp(-d^2/(2 v_i)); printed: exp(-d^2/v_i) as in seed 000 eq. (33)",
        label="translucency falloff",
        tip=("how light through thin parts fades with thickness d (translucent shadow map, eq. 33). exact: "
             "exp(-d²/(2 v_i)); printed: exp(-d²/v_i) as printed in seed 000"))
    tsm_gather: int = field(
        16, ge=0, le=64,
        description="light-space samples per Gaussian wider than two TSM texels: the lit surfaces around the light "
                    "ray are integrated, each sample at its own 3D distance, instead of eq. (33)'s one lit point on "
                    "the ray, so an ear's folds lit from behind glow as in the ground truth (0: eq. 33 on the ray; "
                    "issue 10 item 4, notes/fidelity.md)",
        label="fold gather",
        unit="samples",
        tip=("light through folds: each wide Gaussian gathers this many lit points around the light ray from "
             "the TSM, each at its own 3D distance, so an ear's folds lit from behind glow (0: eq. 33's one "
             "lit point on the ray). Cost: once per light change"))
    energy_conservation: bool = field(True,
        label="energy conservation",
        tip="scale diffuse by 1 - rho_dt (eq. 30-31) at the light and the eye (eq. 28, 34)")
    irradiance_size: int = field(1024, ge=256, le=4096,
        label="blur map size",
        unit="texels",
        tip=("resolution of the texture-space irradiance the blurs run on (eq. 28). Texture-space cost ~ size²"
             " per blur pass"))
    irradiance_size_mode: Literal["fixed", "auto"] = field(
        "fixed", description="auto: the irradiance map (and its blurs) sized from the head's screen coverage, "
                             "irradiance_size at most, with hysteresis (issue 14)",
        label="blur map sizing",
        tip=("fixed: the blur map size above; auto: sized from the head's size on screen (about a texel per "
             "pixel, the size above at most, with hysteresis)"))
    fold_below_texels: float = field(
        1.0, ge=0.0, le=8.0,
        description="a later blur whose sigma increment is under this many (mean) texels is folded: blur_i = "
                    "blur_(i-1), the next blur adds its variance exactly (0: off). 1 by the truth bench: lower "
                    "RMS, p99 and DSSIM than 0 at 256-1024^2 maps, and fewer blurs (notes/perf.md)",
        label="fold narrow blurs",
        unit="texels",
        tip=("skip a later blur whose width step is under this many texels; the next blur adds its width "
             "exactly (0: off). 1: closer to the ground truth than 0"))
    surface_gather_below_texels: float = field(
        2.0, ge=0.0, le=3.0,
        description="a blur step whose sigma is at most this many (mean) texels is a direct sum over the surface "
                    "with 3D distances (eq. 21 at texel resolution: the texels around it, then 2 x 2 blocks out to 12 "
                    "texels) instead of separable taps that assume the surface flat and the stretch constant over "
                    "the kernel: closer to the truth where the atlas is coarse or uneven, ~130 ms more per step and "
                    "light change at 512^2 on llvmpipe (0: every step separable; 3: also the next, wider step; "
                    "issue 10 item 1, notes/fidelity.md)",
        label="surface sum",
        unit="texels",
        tip=("a blur step at most this many texels wide is summed over the surface with 3D distances (closer "
             "to the truth where the atlas is coarse or uneven; slower); 0: every blur separable"))
    skip_gutters: bool = field(
        True, description="blurs shade only the tiles of the UV islands (and the ring a reader reaches); with the "
                          "seam fill, the fill dilates the gutters (images identical; the summed step -14 to -18 % "
                          "at 1024^2 on llvmpipe, issue 27, notes/perf.md)",
        tip=("blurs draw only the tiles of the UV islands and the ring a reader can reach (images identical; "
             "the summed blur step ~15 % cheaper at 1024^2 maps)"))
    half_res_above_texels: float = field(
        2.0, ge=0.0, le=64.0,
        description="a separable blur step whose sigma is at least this many (mean) texels, and every step after "
                    "it, runs on a map of half the side (the irradiance map's half-size gutter and seam maps; "
                    "its readers filter it up): a quarter of the texels for a kernel that spans >= 4 of them "
                    "there, and a cost that grows with the texels as the map grows (issue 27; 0: every step at "
                    "full size; notes/perf.md)",
        label="half-size blurs from",
        unit="texels",
        tip=("a blur at least this many texels wide (and every wider one) runs on a half-size map: about a "
             "quarter of its time; 0: every blur at full size"))
    tsm_auto: bool = field(
        True, description="skip the TSM when no light is behind a part thin enough to transmit that is in view",
        tip="skip the translucent shadow map when no light is behind a thin part that is in view")
    subpixel_kernel_px: float = field(
        0.3, ge=0.0, le=4.0,
        description="when the widest Gaussian's sigma spans under this many pixels on screen, diffusion cannot "
                    "show: blurs, stretch and TSM are skipped and the final pass reads the irradiance (0: never)",
        label="skip blur under",
        unit="px",
        tip=("when the widest Gaussian spans under this many pixels on screen, the diffusion cannot show: the "
             "blurs and TSM are skipped (0: never)"))
    combine_blurs: bool = field(
        True, description="sum the weighted blurs (eq. 34) once in texture space, so a camera move reads one "
                          "texture instead of one per Gaussian (issue 14; equal up to float rounding)",
        label="sum in texture space",
        tip=("sum the weighted blurs and the transmitted light once in texture space, so an orbit reads one "
             "texture (eq. 33-34; equal up to rounding)"))
    view_cull: Literal["view", "off"] = field(
        "off", description="view: d'Eon's texture-space light chain (irradiance, blurs, transmitted light, diffuse "
        "sum) makes only the tiles the current view reads, transitively, and a camera move the tiles not made yet; "
        "the viewer's idle frames make the rest (issue 27, notes/deon_light_move.md section 17; the image "
        "bit-identical). Off by default: at 1024^2 on the head the face's texels are what the view and the blurs "
        "read, so a light move makes ~all of the irradiance and the first blurs, and saves no time measurably",
        label="texture-space view culling",
        tip=("view: texture-space maps are made only where the current view (and the translucency's lit side) "
             "reads them; orbiting adds the missing tiles, idle time the rest. The image is the same; off: every "
             "texel, every time"))

    @field_validator("view_cull", mode="before")
    @classmethod
    def _view_cull_on_off(cls, v: object) -> object:
        # --set reads on / off as true / false
        return {False: "off", True: "view"}.get(v, v) if isinstance(v, bool) else v

    specular_shadows: Literal["texture", "pixel"] = field(
        "texture", description="where the specular's shadow test (eq. 10) is evaluated: texture: once per texel "
        "by the irradiance pass (the same PCF, kept per light), so a camera move does no shadow-map lookups; "
        "pixel: per pixel in the final pass",
        label="specular shadows",
        tip=("where the specular's shadow test (eq. 10) is evaluated. texture: once per irradiance texel, with"
             " the same PCF, kept per light, so orbiting does no shadow-map lookups (a camera move costs about"
             " a quarter less). pixel: per pixel in the final pass"))
    reuse_irradiance_below_texels: float = field(
        0.5, ge=0.0, le=8.0,
        description="blur 1 reuses the irradiance itself when its sigma is under this many (mean) texels: "
                    "a sub-texel 7-tap blur changes nothing",
        label="skip finest blur",
        unit="texels",
        tip=("skip the finest blur when its width is under this many texels (a blur narrower than a texel "
             "changes nothing): blur 1 reuses the irradiance itself"))
    texel_samples: Literal[1, 4] = Field(
        1, description="irradiance samples per texel: 4 averages the hard shadow test (at each sample's sub-texel "
                       "position in the shadow map, no PCF on top) and N.L over a rotated 2 x 2 grid of the texel's "
                       "surface patch, so a texel a shadow edge crosses carries its lit fraction (issue 30 item 4; "
                       "against the judge that shares no shadow green/blue p99 fall, red RMS rises; against the "
                       "ground truth (head, 192^2) ties with the default lights, red RMS rises with the key light "
                       "alone: notes/truth.md session 12)")
    open_border: Literal["reflect", "absorb"] = field(
        "reflect", description="past an open mesh border (with scene.seam_aware): reflect: each blur after the first "
        "reads the odd reflection of the light about the border, so the light earlier steps carried past it comes "
        "back as in one blur of E over the surface (issue 30 item 5); absorb: no light there before every step "
        "(loses light at the rim)",
        label="open border",
        tip=("reflect: past an open mesh border each blur after the first reads the light reflected about the "
             "border, so the rim keeps the light the surface keeps (issue 30); absorb: no light there (the rim"
             " loses light)"))


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
