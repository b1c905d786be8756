"""The screen-space lighting pass (see the package docstring for the contract)."""
from __future__ import annotations

import math

import numpy as np

from skinviewer.core.graph import Pass, Reflection, TexSpec
from skinviewer.core.settings import REGIONS
from skinviewer.passes.common import (
    MAX_LIGHTS,
    bind_specular,
    bind_surface,
    declare_lighting,
    declare_specular,
    set_camera,
    set_lighting,
)
from skinviewer.scene.camera import gl_bytes, light_space

DIFFUSE = "ss_diffuse"
SPECULAR = "ss_specular"
DEPTH = "ss_depth"
ALBEDO = "ss_albedo"
MAX_TR_GAUSSIANS = 8
# [SEP] SSSSTransmittance: scale = 8.25 (1 - translucency) / sssWidth, sssWidth <-> 3 mm of profile
TR_SCALE = 8.25 / 3.0


def screen_size(r) -> tuple[int, int]:
    """The render size (declares render.width/height)."""
    return int(r.setting("render.width")), int(r.setting("render.height"))


def focal_px(fov_y_deg: float, height: int) -> float:
    """Pixels per unit length at unit depth: H / (2 tan(fov_y / 2))."""
    return height / (2.0 * math.tan(math.radians(fov_y_deg) / 2.0))


def texturing_exponent(texturing: str, mix: float) -> float:
    """f of seed 001 §3.6: albedo^f before the blur, albedo^(1-f) after."""
    return {"post": 0.0, "pre": 1.0}.get(texturing, float(mix))


class ScreenLightingPass(Pass):
    """Diffuse (x albedo^f, + transmittance), specular, linear depth + gradient, SSS mask and
    the post-scatter albedo, from the camera. ``transmittance_profile`` is the settings path of a
    list of Gaussians (variance mm^2, RGB weights) whose T(d) the transmittance uses."""
    name = "ss_lighting"
    view_dependent = True

    def __init__(self, transmittance_profile: str = "deon.gaussians"):
        self.transmittance_profile = transmittance_profile

    def reflect(self, r: Reflection) -> None:
        declare_lighting(r)
        declare_specular(r)
        r.setting("screen.texturing")
        r.setting("screen.mix")
        r.setting("screen.non_skin_regions")
        if r.setting("transmittance.enabled"):
            r.setting("transmittance")
            r.setting(self.transmittance_profile)
        size = screen_size(r)
        r.program("ss_lighting")
        r.output(DIFFUSE, TexSpec(size, 4, "f4", depth=True))
        r.output(SPECULAR, TexSpec(size, 4, "f2"))
        r.output(DEPTH, TexSpec(size, 4, "f4", filter="nearest"))
        r.output(ALBEDO, TexSpec(size, 4, "f2"))

    def transmittance_gaussians(self, ec) -> list[tuple[float, tuple[float, float, float]]]:
        return [(float(g.variance), tuple(g.weights)) for g in ec.setting(self.transmittance_profile)]

    def execute(self, ec) -> None:
        prog = ec.program("ss_lighting")
        scene = ec.scene
        set_camera(ec, prog)
        ec.set(prog, "u_view", gl_bytes(ec.view.view))
        ec.set(prog, "u_mm_per_unit", float(scene.mm_per_unit), optional=True)
        bind_surface(ec, prog)
        set_lighting(ec, prog)
        bind_specular(ec, prog)
        f = texturing_exponent(ec.setting("screen.texturing"), ec.setting("screen.mix"))
        ec.set(prog, "u_mix", float(f), optional=True)
        non_skin = set(ec.setting("screen.non_skin_regions"))
        sss = np.array([0.0 if name in non_skin else 1.0 for name in REGIONS], np.float32)
        ec.set(prog, "u_region_sss", sss, optional=True)
        ec.set(prog, "u_has_regions", 1 if scene.has_region_map and non_skin else 0, optional=True)
        self._transmittance(ec, prog)
        ec.draw_mesh(prog, DIFFUSE, SPECULAR, DEPTH, ALBEDO)

    def _transmittance(self, ec, prog) -> None:
        on = bool(ec.setting("transmittance.enabled"))
        ec.set(prog, "u_tr", 1 if on else 0, optional=True)
        if not on:
            return
        tr = ec.setting("transmittance")
        gs = self.transmittance_gaussians(ec)[:MAX_TR_GAUSSIANS]
        w = np.zeros((MAX_TR_GAUSSIANS, 3), np.float32)
        v = np.zeros(MAX_TR_GAUSSIANS, np.float32)
        for i, (var, wt) in enumerate(gs):
            w[i], v[i] = wt, var
        ec.set(prog, "u_tr_w", w, optional=True)
        ec.set(prog, "u_tr_v", v, optional=True)
        ec.set(prog, "u_tr_count", len(gs), optional=True)
        ec.set(prog, "u_tr_scale", float(TR_SCALE * (1.0 - tr.translucency)), optional=True)
        ec.set(prog, "u_tr_div", 1.0 if tr.form == "printed" else 2.0, optional=True)
        ec.set(prog, "u_tr_wrap", float(tr.wrap), optional=True)
        scene = ec.scene
        inv = np.tile(np.eye(4, dtype=np.float32), (4, 1, 1))
        active = [l for l in ec.setting("lights")[:MAX_LIGHTS] if l.enabled]
        for slot, l in enumerate(active):
            inv[slot] = np.linalg.inv(light_space(l, scene.center, scene.radius).gl_matrix).T
        ec.set(prog, "u_light_matrix_inv", np.ascontiguousarray(inv, np.float32).tobytes(), optional=True)
