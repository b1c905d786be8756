"""Gosselin et al. 2004 texture-space skin (seed 000 §4.1, eq. 1-19).

    shadow_map_i --> gosselin_light_map --> gosselin_blur --> gosselin_final --> output
    gutter_map  -/        gosselin_radius -/   beckmann_lut -/ (mode beckmann_lut only)
                          (or gosselin_stretch, radius_mode "mm")

* ``gosselin_light_map`` (eq. 8-10): the mesh unwrapped into texture space, sum of
  fac_shadow * Lc * max(N.L, 0) over the lights (mesh normal map applied), f4 RGBA (a 1e5 light does
  not overflow), alpha 1 on the islands, gutters filled with the nearest island texel (dilate).
  View-independent.
* ``gosselin_radius`` (eq. 12 per texel): R = kernel_size_r * scale_x_r * gosselin.scale_x +
  scale_y_r * gosselin.scale_y for the region r of the texel (region map; a mesh without one is all
  "other"), in texels **at the 1024 reference size**, times light_map_size / 1024. So eq. 12 holds
  exactly at 1024 (size = 1/1024) and changing light_map_size keeps the blur the same width on the
  surface (in mm) instead of changing the look. R is clamped to [0, light_map_size]. To avoid seams
  where regions meet, gutters first take the radius of their nearest island texel, then the map is
  smoothed with a Gaussian of sigma = clamp(0.5 * R_max, 1, 24) texels (R_max: the largest region
  radius in the map), so R varies continuously over about one blur footprint across a border.
* ``gosselin.radius_mode = "mm"`` (issue 10 item 6): instead of eq. 12's texels, each channel's
  radius is R_c mm with iterations x m R_c^2 = the d'Eon profile's per-axis variance (physics/
  poisson.radii_mm; m the kernel's second moment), turned into UV per texel by a stretch map at the
  light-map size, so the blur is the same on the surface at any map size and compares with d'Eon.
* ``gosselin_blur`` (eq. 11-13): ``iterations`` 13-tap Poisson blurs (POISSON_12), ping-pong in
  scratch textures, each iteration reading the previous one, gutters re-dilated after every
  iteration so islands never bleed into each other. 0 iterations (or R = 0) = the light map itself.
  A gather with a translation-invariant kernel keeps the total exactly (sum(f * k) = sum f * sum k)
  wherever the taps stay inside the island; measured in tests/test_gosselin.py.
* ``gosselin_final`` (eq. 17-19), the only view-dependent pass: C * blurred + specular. The
  specular is Kelemen/Szirmay-Kalos (listing 14-3, includes N.L) per light times Lc, attenuated by
  the blurred light map (eq. 18) -- see shaders/gosselin_final.frag and ``gosselin.specular_shadow``:
  by default a visibility LUM(blurred) / LUM(unshadowed irradiance) clamped to [0, 1], because
  eq. 18 as printed multiplies Lc by an irradiance that already contains Lc (and N.L).
"""
from __future__ import annotations

from typing import Any

import numpy as np

from skinviewer.ground.settings import REGIONS, RegionKernel
from skinviewer.kernel.pass_api import Pass, Reflection, TexSpec, declare, whole
from skinviewer.passes.common import (
    LIT,
    bind_specular,
    bind_surface,
    declare_lighting,
    declare_lit,
    declare_specular,
    declare_view_mesh,
    draw_view_mesh,
    set_camera,
    set_lighting,
)
from skinviewer.passes.environment import declare_environment, set_environment
from skinviewer.passes.texture_space import (
    declare_shaded,
    dilate,
    gutter_resource,
    read_gutter,
    seam_resource,
    shade_dilated,
)
from skinviewer.physics.poisson import POISSON_12, radii_mm

LIGHT_MAP = "gosselin_light_map"
RADIUS_MAP = "gosselin_radius"
BLURRED = "gosselin_blurred"
STRETCH = "gosselin_stretch"  # UV per mm at the light-map size (seed 000 eq. 27; radius_mode "mm")


def light_map_size(r) -> int:
    """gosselin.light_map_size, declared (the light map, its blurs, gutter and stretch maps)."""
    return int(r.settings.gosselin.light_map_size)

REFERENCE_SIZE = 1024  # eq. 12's size = 1/1024: radii are "texels at 1024"
MAX_SMOOTH_SIGMA = 24.0


def _map_spec(size: int) -> TexSpec:
    return TexSpec((size, size), 4, "f4")


class GosselinLightMapPass(Pass):
    """Eq. 8-10 into an f4 texture of light_map_size; gutters dilated."""
    name = "gosselin_light_map"
    tileable = True  # texel shading in row bands under a frame budget, dilated after the last (issue 27)

    def reflect(self, r: Reflection) -> None:
        lighting = {**declare_lighting(r), **declare_environment(r, specular=False)}
        size = light_map_size(r)
        declare_shaded(r, "light_map", size, LIGHT_MAP, _map_spec(size), **lighting)

    def execute(self, ec) -> None:
        prog = ec.program(ec.plan.shading.program)
        bind_surface(ec, prog)
        set_lighting(ec, prog)
        set_environment(ec, prog, specular=False)
        shade_dilated(ec, prog, LIGHT_MAP)


def region_radii(g, size: int) -> np.ndarray:
    """Eq. 12's R (texels at ``size``) per region ID, float64 (len(REGIONS),). A region missing from
    ``gosselin.regions`` uses "other" (or the RegionKernel defaults)."""
    fallback = g.regions.get("other", RegionKernel())
    out = np.zeros(len(REGIONS))
    for k, name in enumerate(REGIONS):
        rk = g.regions.get(name, fallback)
        out[k] = rk.kernel_size * rk.scale_x * g.scale_x + rk.scale_y * g.scale_y
    out *= size / REFERENCE_SIZE
    return np.clip(np.nan_to_num(out, nan=0.0, posinf=size, neginf=0.0), 0.0, float(size))


def radius_map(region_ids: np.ndarray, radii: np.ndarray, size: int,
               gutter: np.ndarray | None = None) -> np.ndarray:
    """(size, size) float32 per-texel radius in texels: region map resampled (nearest) to ``size``,
    unknown IDs -> "other", gutters take their nearest island texel's radius (``gutter``: the
    gutter table, RG = source texel), then a Gaussian of sigma = clamp(0.5 R_max, 1, 24)."""
    ids = np.asarray(region_ids)
    if ids.ndim == 3:
        ids = ids[..., 0]
    h, w = ids.shape
    rows = np.minimum(((np.arange(size) + 0.5) * h / size).astype(np.int64), h - 1)
    cols = np.minimum(((np.arange(size) + 0.5) * w / size).astype(np.int64), w - 1)
    rid = ids[rows][:, cols].astype(np.int64)
    rid = np.where((rid >= 0) & (rid < len(radii)), rid, 0)
    rad = radii[rid]
    if gutter is not None:
        ix = np.clip(gutter[..., 0].astype(np.int64), 0, size - 1)
        iy = np.clip(gutter[..., 1].astype(np.int64), 0, size - 1)
        rad = rad[iy, ix]
        present = np.unique(rid[iy, ix])
    else:
        present = np.unique(rid)
    r_max = float(radii[present].max()) if present.size else 0.0
    if r_max > 0.0 and float(radii[present].min()) != r_max:
        sigma = min(max(0.5 * r_max, 1.0), MAX_SMOOTH_SIGMA)
        from scipy import ndimage  # here, not at import: scipy costs start-up (issue 14)
        rad = ndimage.gaussian_filter(rad, sigma, mode="nearest")
    return np.clip(rad, 0.0, float(size)).astype(np.float32)


class GosselinRadiusMapPass(Pass):
    """Per-texel eq. 12 radius (texels) from the region map and the kernel settings, smoothed so the
    blur has no seam at region borders. Re-runs on the region map (scene), kernel settings, size."""
    name = "gosselin_radius"

    def reflect(self, r: Reflection) -> None:
        size = light_map_size(r)
        g = r.settings.gosselin
        declare(g.regions, g.scale_x, g.scale_y)  # what region_radii reads
        r.plan(size=size, gutter=gutter_resource(size))
        r.input(r.planned.gutter)
        r.output(RADIUS_MAP, TexSpec((size, size), 1, "f4", filter="nearest"))

    def execute(self, ec) -> None:
        size = ec.plan.size
        radii = region_radii(ec.settings.gosselin, size)
        gtex = ec.input(ec.plan.gutter)
        gutter = read_gutter(gtex)
        rad = radius_map(ec.scene.region_ids, radii, size, gutter)
        ec.output(RADIUS_MAP).write(np.ascontiguousarray(rad).tobytes())


class PoissonBlurPass(Pass):
    """``gosselin.iterations`` Poisson blurs of the light map (eq. 11-13), ping-pong, gutters
    re-dilated after each iteration."""
    name = "gosselin_blur"
    tileable = True  # each draw in row bands under a frame budget, in order (issue 27)

    def reflect(self, r: Reflection) -> None:
        size = light_map_size(r)
        declare(r.settings.gosselin.iterations)
        r.input(LIGHT_MAP)
        mm = r.settings.gosselin.radius_mode == "mm"
        if mm:  # per-channel radii (mm) from the d'Eon profile, through the stretch map
            declare(r.settings.deon.gaussians)
            r.input(STRETCH)
        else:
            r.input(RADIUS_MAP)
        seam = seam_resource(size) if r.settings.scene.seam_aware else None
        r.plan(iterations=int(r.settings.gosselin.iterations), gutter=gutter_resource(size), seam=seam,
               radius_mm=mm, spec=_map_spec(size))
        r.input(r.planned.gutter)
        if seam:
            r.input(seam)
        zones = {"ISLAND_ZONES": 1} if seam else {}  # no tap on another island
        r.program("poisson_blur", **({"RADIUS_MM": 1} if mm else {}), **zones)
        if seam:
            r.program("seam_fill")
        r.program("dilate")
        r.output(BLURRED, r.planned.spec)

    def execute(self, ec) -> None:
        plan = ec.plan
        n, gutter, seam, spec = plan.iterations, plan.gutter, plan.seam, plan.spec
        if n <= 0:
            for _d, sub, subs in ec.units(1):
                with ec.band(sub, subs):
                    dilate(ec, LIGHT_MAP, gutter, BLURRED)  # a copy: the light map is already dilated
            return
        prog = ec.program("poisson_blur")
        ec.set(prog, "u_poisson", np.asarray(POISSON_12, dtype=np.float32))
        ec.bind(prog, "gutter", gutter)
        if seam:  # taps that leave their island read the surface across the seam (seam_fill.frag)
            fill = ec.program("seam_fill")
            ec.bind(fill, "seam_map", seam)
            ec.set(fill, "u_past_border_dark", True)
            ec.bind(prog, "seam_map", seam)
            filled = ec.held("filled", spec)[0]
        if plan.radius_mm:
            gs = whole(ec.settings.deon.gaussians)
            radii = radii_mm([g.variance for g in gs], [g.weights for g in gs], n)
            ec.set(prog, "u_radius_mm", tuple(float(x) for x in radii))
            ec.bind(prog, "stretch_map", STRETCH)
        else:
            ec.bind(prog, "radius_map", RADIUS_MAP)
        # scratch kept across the pass's bands (issue 27): under the viewer's frame budget each draw
        # (seam fill, blur, dilation per iteration) runs in row bands, complete before the next starts
        tmp = ec.held("tmp", spec)[0]
        ping = ec.held("ping", spec)[0] if n > 1 else None
        draws: list[tuple[str, Any, Any]] = []  # (what, source, target) in order
        cur: Any = LIGHT_MAP  # the light map's name, then the scratch texture
        for k in range(n):
            if seam:
                draws.append(("fill", cur, filled))
            draws.append(("blur", filled if seam else cur, tmp))
            last = k == n - 1
            draws.append(("dilate", tmp, BLURRED if last or ping is None else ping))
            cur = ping
        for d, sub, subs in ec.units(len(draws)):
            what, source, target = draws[d]
            with ec.band(sub, subs):
                if what == "fill":
                    ec.bind(fill, "source", source)
                    ec.draw_fullscreen(fill, target)
                elif what == "blur":
                    ec.bind(prog, "source", source)
                    ec.draw_fullscreen(prog, target)
                else:
                    dilate(ec, source, gutter, target)


class GosselinFinalPass(Pass):
    """Eq. 17-19 on the mesh from the camera; writes ``lit`` (RGBA f2, alpha 1 on the mesh)."""
    name = "gosselin_final"
    view_dependent = True
    tileable = True  # in row bands under the viewer's frame budget (issue 27)

    def reflect(self, r: Reflection) -> None:
        lighting = declare_lighting(r)
        declare_specular(r)
        declare(r.settings.gosselin.specular_shadow)
        r.input(BLURRED)
        declare_lit(r, "gosselin_final", **lighting, **declare_environment(r))
        declare_view_mesh(r)

    def execute(self, ec) -> None:
        prog = ec.program("gosselin_final")
        set_camera(ec, prog)
        ec.set(prog, "u_spec_shadow", ec.settings.gosselin.specular_shadow == "printed")
        bind_surface(ec, prog)
        ec.bind(prog, "blurred", BLURRED)
        bind_specular(ec, prog)
        set_lighting(ec, prog)
        set_environment(ec, prog)
        draw_view_mesh(ec, prog, LIT)
