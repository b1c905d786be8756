"""Jimenez 2010's transmittance (seed 001 §3.5, eq. 3.18; spec §6.2) for the passes that shade it: the
uniforms of shaders/lib/tr_thickness.glsl (the thickness from the shadow maps) and lib/tr_profile.glsl
(the profile T(d)). Used by the screen-space lighting and transmittance passes and by pre-integrated
skin (passes/penner.py). ``profile(settings)``: the Gaussians (variance mm^2, RGB weights) of T(d)."""
from __future__ import annotations

import numpy as np

from skinviewer.ground.constants import MAX_GAUSSIANS, MAX_LIGHTS
from skinviewer.kernel.pass_api import declare, whole
from skinviewer.passes.environment import env_defines
from skinviewer.passes.rules import analytic_on
from skinviewer.physics import burley as B
from skinviewer.physics.transmittance import SEP_SCALE, SEP_WIDTH_MM

TR_SLOTS = 4  # ss_transmitted_k targets at most (ss_lighting's four targets + these <= 8 draw buffers)


def transmittance_slots(r) -> int:
    """The transmittance terms the lighting pass measures, one per shadow-casting light and, last,
    the environment's translucency (issue 32: its back-side irradiance at the baked thickness; when
    the environment has its visibility bake), at most TR_SLOTS (declares transmittance.enabled and
    the lights); 0: the transmittance is off or nothing comes through."""
    if not r.settings.transmittance.enabled:
        return 0
    n = sum(1 for l in whole(r.settings.lights)[:MAX_LIGHTS] if analytic_on(l) and l.cast_shadow)
    if env_defines(r).get("ENV_RAYS", 0) > 0:
        n += 1
    return min(n, TR_SLOTS)


def deon_gaussians(settings):
    """The profile the screen-space transmittance uses by default: ``deon.gaussians``."""
    return settings.deon.gaussians


def set_thickness_uniforms(ec, prog) -> None:
    """lib/tr_thickness.glsl: each lit slot's inverse light matrix, the shadow maps' planned size (the
    maps as made: shadow.map_size_mode auto), the wrap and mm per mesh unit. The pass has declared the
    lighting (declare_lighting) and transmittance.wrap."""
    scene = ec.scene
    inv = np.tile(np.eye(4, dtype=np.float32), (MAX_LIGHTS, 1, 1))
    lights = whole(ec.settings.lights)
    for slot, i in enumerate(ec.plan.light_slots):  # the slots of set_lighting (declare_lighting)
        inv[slot] = np.linalg.inv(scene.light_space(lights[i]).gl_matrix).T  # column-major
    ec.uniforms(prog, u_tr_wrap=float(ec.settings.transmittance.wrap), u_light_matrix_inv=inv,
                u_shadow_map_size=int(ec.plan.shadow_map_size), u_mm_per_unit=float(scene.mm_per_unit))


def declare_profile(r, profile, model: int) -> None:
    """Declare what set_profile_uniforms reads: translucency and form, and the profile (the sum of
    Gaussians ``profile(settings)``, or Burley's section for model 1 or 2)."""
    tr = r.settings.transmittance
    declare(tr.translucency, tr.form)
    if model:
        b = r.settings.burley
        declare(b.albedo, b.mfp, b.fit, b.scale)  # physics.burley.profile_of_section
    else:
        declare(profile(r.settings))


def set_profile_uniforms(ec, prog, profile, model: int) -> None:
    """lib/tr_profile.glsl: model 0, Jimenez 2010's sum of Gaussians with [SEP]'s profile distance per mm
    of thickness, 8.25 (1 - translucency) / sssWidth; 1 or 2, Burley's T(t), S = 1/d per channel
    (spec §5.4)."""
    tr = ec.settings.transmittance
    gs = [] if model else [(float(g.variance), tuple(g.weights)) for g in whole(profile(ec.settings))][:MAX_GAUSSIANS]
    w = np.zeros((MAX_GAUSSIANS, 3), np.float32)
    v = np.zeros(MAX_GAUSSIANS, np.float32)
    for i, (var, wt) in enumerate(gs):
        w[i], v[i] = wt, var
    if model:
        S = B.profile_of_section(ec.settings.burley).S
        ec.uniforms(prog, u_tr_model=model, u_tr_S=tuple(float(x) for x in S), u_tr_scale=1.0)
    else:
        ec.uniforms(prog, u_tr_model=0, u_tr_scale=float(SEP_SCALE * (1.0 - tr.translucency) / SEP_WIDTH_MM))
    ec.uniforms(prog, u_tr_w=w, u_tr_v=v, u_tr_count=len(gs), u_tr_div=1.0 if tr.form == "printed" else 2.0)
