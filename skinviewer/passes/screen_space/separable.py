"""Jimenez et al. 2015 separable subsurface scattering (seed 001 §3.3; spec §4): one
pre-integrated separable kernel (skinviewer.physics.separable.separable_kernel, [SEP]
calculateKernel with strength/falloff), two 1-D passes with the follow-surface depth test and the
per-pixel rotation of the inner taps (seed 001 §3.3.4).

    ss_lighting        -> ss_diffuse, ss_depth, ...
    separable_blur     ss_diffuse -> "separable_diffuse"   (separable.*, fov)
    ss_combine         separable_diffuse -> lit
"""
from __future__ import annotations

from skinviewer.kernel.pass_api import declare
from skinviewer.passes.screen_space.blur import SeparableScreenBlur
from skinviewer.passes.screen_space.lighting import DIFFUSE, screen_size
from skinviewer.physics.separable import focal_px, separable_kernel

OUTPUT = "separable_diffuse"


class SeparableBlurPass(SeparableScreenBlur):

    def __init__(self):
        super().__init__("separable_blur", DIFFUSE, OUTPUT)

    def declare(self, r) -> bool:
        sp = r.settings.separable
        declare(sp.taps, sp.strength, sp.falloff, sp.width_mm, sp.follow_surface, sp.follow_surface_mm, sp.rotation,
                sp.rotation_fraction)
        # the tap spacing's focal length in pixels (eq. 3.2's stretch)
        r.plan(focal=float(focal_px(r.settings.camera.fov_y, screen_size(r)[1])), taps=int(sp.taps))
        r.program("ss_separable_blur", TAPS=int(sp.taps))
        return True

    def program(self, ec):
        return ec.program("ss_separable_blur")

    def set_uniforms(self, ec, prog) -> None:
        sp = ec.settings.separable
        k, x = separable_kernel(ec.plan.taps, sp.strength, sp.falloff)
        ec.uniforms(prog, u_k=k, u_x=x, u_width_mm=float(sp.width_mm),
                    u_focal=ec.plan.focal,
                    u_follow=bool(sp.follow_surface), u_follow_mm=float(sp.follow_surface_mm),
                    u_rotate=bool(sp.rotation and sp.rotation_fraction > 0),
                    u_rot_fraction=float(sp.rotation_fraction))
