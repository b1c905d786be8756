"""The screen-space lighting pass (see the package docstring for the contract)."""
from __future__ import annotations

import numpy as np

from skinviewer.ground.constants import REGIONS
from skinviewer.kernel.pass_api import Pass, Reflection, TexSpec, declare
from skinviewer.passes.common import (
    bind_specular,
    bind_surface,
    declare_lighting,
    declare_specular,
    declare_view_mesh,
    draw_view_mesh,
    set_camera,
    set_lighting,
)
from skinviewer.passes.environment import declare_environment, set_environment
from skinviewer.passes.transmittance import (  # noqa: F401  (TR_SLOTS: part of the package API)
    TR_SLOTS,
    declare_profile,
    deon_gaussians,
    set_profile_uniforms,
    set_thickness_uniforms,
    transmittance_slots,
)
from skinviewer.physics.separable import focal_px  # noqa: F401  (part of the framework's API)
from skinviewer.scene.camera import gl_bytes

DIFFUSE = "ss_diffuse"
SPECULAR = "ss_specular"
DEPTH = "ss_depth"
ALBEDO = "ss_albedo"
DIRECT = "ss_diffuse_direct"  # the lighting's diffuse without the transmittance (when it is on)


def transmitted_resource(k: int) -> str:
    """The k-th shadow-casting light's transmittance weight and thickness (ss_lighting.frag)."""
    return f"ss_transmitted_{k}"


def screen_size(r) -> tuple[int, int]:
    """The render size (declares render.width/height)."""
    return int(r.settings.render.width), int(r.settings.render.height)


def texturing_exponent(texturing: str, mix: float) -> float:
    """f of seed 001 §3.6: albedo^f before the blur, albedo^(1-f) after."""
    return {"post": 0.0, "pre": 1.0}.get(texturing, float(mix))


class ScreenLightingPass(Pass):
    """Diffuse (x albedo^f), specular, linear depth + gradient, SSS mask and the post-scatter
    albedo, from the camera; with the transmittance on, per shadow-casting light its thickness and
    weight, and the diffuse goes to ss_diffuse_direct (ScreenTransmittancePass adds T(d) into
    ss_diffuse); the profile is ScreenTransmittancePass's alone."""
    name = "ss_lighting"
    view_dependent = True
    tileable = True  # one view-mesh draw (four targets): in row bands under a frame budget (issue 27)

    def reflect(self, r: Reflection) -> None:
        defines = {**declare_lighting(r), **declare_environment(r)}
        declare_specular(r)
        sc = r.settings.screen
        declare(sc.texturing, sc.mix, sc.non_skin_regions)
        k = transmittance_slots(r)
        if k:  # the thickness and weights here; the profile in ScreenTransmittancePass
            declare(r.settings.transmittance.wrap)
        size = screen_size(r)
        r.program("ss_lighting", TR_TARGETS=k, **defines)
        declare_view_mesh(r)
        r.output(DIRECT if k else DIFFUSE, TexSpec(size, 4, "f4", depth=True))
        r.output(SPECULAR, TexSpec(size, 4, "f2"))
        # linear: the separable blur's follow-surface test reads the depth where its tap reads the
        # (bilinear) colour; nearest gave a sub-pixel tap the centre's own depth, so it gathered its
        # neighbour's colour across any depth step (every other reader uses texelFetch)
        r.output(DEPTH, TexSpec(size, 4, "f4"))
        r.output(ALBEDO, TexSpec(size, 4, "f2"))
        transmitted = tuple(transmitted_resource(j) for j in range(k))
        for res in transmitted:
            r.output(res, TexSpec(size, 4, "f4"))
        r.plan(transmitted=transmitted)  # k = len: the transmittance terms this frame

    def execute(self, ec) -> None:
        prog = ec.program("ss_lighting")
        scene = ec.scene
        set_camera(ec, prog)
        bind_surface(ec, prog)
        set_lighting(ec, prog)
        set_environment(ec, prog)
        bind_specular(ec, prog)
        sc = ec.settings.screen
        non_skin = set(sc.non_skin_regions)
        sss = np.array([0.0 if name in non_skin else 1.0 for name in REGIONS], np.float32)
        ec.uniforms(prog, u_view=gl_bytes(ec.view.view), u_mm_per_unit=float(scene.mm_per_unit),
                    u_mix=float(texturing_exponent(sc.texturing, sc.mix)), u_region_sss=sss,
                    u_has_regions=bool(scene.has_region_map and non_skin))
        transmitted = ec.plan.transmitted
        ec.set(prog, "u_tr", len(transmitted) > 0)
        if transmitted:
            set_thickness_uniforms(ec, prog)
        draw_view_mesh(ec, prog, DIRECT if transmitted else DIFFUSE, SPECULAR, DEPTH, ALBEDO, *transmitted)


class ScreenTransmittancePass(Pass):
    """Jimenez 2010's transmittance profile applied to the lighting pass's thickness and weights
    (seed 001 eq. 3.18, spec §6.2; Burley's T(t) for the Burley techniques, spec §5.4): ss_diffuse =
    the direct diffuse + sum_k weight_k T(thickness_k x scale). A profile, translucency or form edit
    re-runs this full-screen pass only, not the lighting (issue 27). ``transmittance_profile(settings)``:
    the Gaussians (variance mm^2, RGB weights) whose T(d) it uses, from ``r.settings``/``ec.settings``."""
    name = "ss_transmittance"
    tileable = True  # one full-screen draw: in row bands under a frame budget

    def __init__(self, transmittance_profile=deon_gaussians, burley: bool = False):
        self.transmittance_profile = transmittance_profile
        self.burley = burley  # the Burley techniques: burley.transmission picks Burley's T(t) (spec §5.4)

    def _burley_model(self, r) -> int:
        """0: Jimenez 2010's Gaussian T(d); 1: Burley closed form; 2: Burley thick (HDRP)."""
        if not self.burley:
            return 0
        return {"jimenez2010": 0, "closed-form": 1, "thick": 2}[r.settings.burley.transmission]

    def reflect(self, r: Reflection) -> None:
        k = transmittance_slots(r)
        if not k:
            r.skip("no transmittance (transmittance.enabled off, or no light casts a shadow)")
            return
        model = self._burley_model(r)
        declare_profile(r, self.transmittance_profile, model)
        r.program("ss_transmittance", TR_TARGETS=k)
        r.input(DIRECT)
        transmitted = tuple(transmitted_resource(j) for j in range(k))
        for res in transmitted:
            r.input(res)
        r.plan(model=model, transmitted=transmitted)
        r.output(DIFFUSE, TexSpec(screen_size(r), 4, "f4"))

    def execute(self, ec) -> None:
        prog = ec.program("ss_transmittance")
        ec.bind(prog, "direct", DIRECT)
        for j, res in enumerate(ec.plan.transmitted):
            ec.bind(prog, f"transmitted{j}", res)
        set_profile_uniforms(ec, prog, self.transmittance_profile, ec.plan.model)
        with ec.band():
            ec.draw_fullscreen(prog, DIFFUSE)


def screen_lighting(transmittance_profile=deon_gaussians, burley: bool = False) -> list[Pass]:
    """The screen-space techniques' lighting: ScreenLightingPass and, when the transmittance is on,
    ScreenTransmittancePass (which writes ss_diffuse then)."""
    return [ScreenLightingPass(), ScreenTransmittancePass(transmittance_profile, burley)]
