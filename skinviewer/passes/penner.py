"""Pre-integrated skin (Penner & Borshukov, GPU Pro 2, 2011): two lookup tables built in numpy from the
profile in use (physics/penner.py), and one pass that shades the mesh from the camera with them.

    penner_luts   ring_lut, penumbra_lut,  deon.gaussians, penner.*      (no scene, no camera)
                  penner_env_bands
    penner        lit                      lights, shadow maps, LUTs, specular, rho_dt, and with
                                           transmittance.enabled Jimenez 2010's transmittance
"""
from __future__ import annotations

import functools

import numpy as np

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
from skinviewer.passes.rho_dt import RHO_DT_RESOURCE
from skinviewer.passes.transmittance import (
    declare_profile,
    deon_gaussians,
    set_profile_uniforms,
    set_thickness_uniforms,
    transmittance_slots,
)
from skinviewer.physics import penner

RING_LUT = "ring_lut"
PENUMBRA_LUT = "penumbra_lut"
ENV_BANDS_LUT = "penner_env_bands"  # the environment's SH band weights per curvature (physics/penner.env_band_factors)


def profile(gaussians) -> tuple[tuple[float, tuple[float, float, float]], ...]:
    """The sum of Gaussians in use, as (variance mm^2, RGB weights) pairs (hashable, for the cache)."""
    return tuple((float(g.variance), (float(g.weights[0]), float(g.weights[1]), float(g.weights[2])))
                 for g in gaussians)


@functools.lru_cache(maxsize=8)
def _tables(gs, size: int, max_curvature: float, max_width: float) -> tuple[bytes, bytes, bytes]:
    ring = penner.ring_lut(list(gs), size, max_curvature)
    pen = penner.penumbra_lut(list(gs), size, max_width)
    bands = penner.env_band_factors(ring).reshape(size, 3, 3)  # rows: curvature, columns: band, RGB
    return tuple(np.ascontiguousarray(a, np.float32).tobytes() for a in (ring, pen, bands))  # type: ignore[return-value]


class PennerLutPass(Pass):
    """The ring table D(N.L, curvature) and the penumbra table P(s, W), RGB f4, from deon.gaussians."""
    name = "penner_luts"
    uses_scene = False

    def reflect(self, r: Reflection) -> None:
        declare(r.settings.deon.gaussians)
        p = r.settings.penner
        n = p.lut_size
        declare(p.max_curvature, p.penumbra_max_mm)
        r.output(RING_LUT, TexSpec((n, n), 3, "f4", filter="linear"))
        r.output(PENUMBRA_LUT, TexSpec((n, n), 3, "f4", filter="linear"))
        r.output(ENV_BANDS_LUT, TexSpec((3, n), 3, "f4", filter="linear"))

    def execute(self, ec) -> None:
        p = ec.settings.penner
        ring, pen, bands = _tables(profile(whole(ec.settings.deon.gaussians)), int(p.lut_size), float(p.max_curvature),
                                   float(p.penumbra_max_mm))
        for name, data in ((RING_LUT, ring), (PENUMBRA_LUT, pen), (ENV_BANDS_LUT, bands)):
            tex = ec.output(name)
            tex.repeat_x = tex.repeat_y = False
            tex.write(data)


class PennerPass(Pass):
    """The mesh from the camera, lit through the tables; writes ``lit`` (RGBA f2)."""
    name = "penner"
    view_dependent = True
    tileable = True  # in row bands under the viewer's frame budget (issue 27)

    def reflect(self, r: Reflection) -> None:
        lighting = declare_lighting(r)
        declare_specular(r)
        p = r.settings.penner
        declare(p.max_curvature, p.curvature_scale, p.penumbra, p.penumbra_max_mm)
        r.input(RING_LUT)
        if p.penumbra:
            r.input(PENUMBRA_LUT)
        if r.settings.deon.energy_conservation:
            r.input(RHO_DT_RESOURCE)
        env = declare_environment(r)
        if env:
            r.input(ENV_BANDS_LUT)
        tr = transmittance_slots(r) > 0  # a shadow-casting light or the environment's bake
        if tr:  # Jimenez 2010 through thin parts, the profile in use (as ssss and separable)
            declare(r.settings.transmittance.wrap)
            declare_profile(r, deon_gaussians, 0)
        r.plan(transmittance=tr)
        declare_lit(r, "penner", **lighting, **env, PENNER_TR=int(tr))
        declare_view_mesh(r)

    def execute(self, ec) -> None:
        prog = ec.program("penner")
        p = ec.settings.penner
        set_camera(ec, prog)
        bind_surface(ec, prog)
        bind_specular(ec, prog)
        set_lighting(ec, prog)
        set_environment(ec, prog)
        ec.bind(prog, "ring_lut", RING_LUT)
        if ec.has_input(ENV_BANDS_LUT):
            ec.bind(prog, "penner_env_bands", ENV_BANDS_LUT)
        penumbra = ec.has_input(PENUMBRA_LUT)
        if penumbra:
            ec.bind(prog, "penumbra_lut", PENUMBRA_LUT)
        energy = ec.has_input(RHO_DT_RESOURCE)
        if energy:
            ec.bind(prog, "rho_dt_tex", RHO_DT_RESOURCE)
        pcf = int(ec.settings.shadow.pcf)
        ec.uniforms(prog, u_energy=energy, u_penumbra=penumbra,
                    u_curvature_scale=float(p.curvature_scale) / float(p.max_curvature),
                    u_penumbra_scale=float(ec.scene.mm_per_unit) / float(p.penumbra_max_mm),
                    u_penumbra_texels=float(2 * pcf + 1))
        if ec.plan.transmittance:
            set_thickness_uniforms(ec, prog)
            set_profile_uniforms(ec, prog, deon_gaussians, 0)
        draw_view_mesh(ec, prog, LIT)
