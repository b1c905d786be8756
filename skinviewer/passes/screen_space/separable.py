"""Jimenez et al. 2015 separable subsurface scattering (seed 001 §3.3; spec §4): one
pre-integrated separable kernel (skinviewer.physics.separable.separable_kernel, [SEP]
calculateKernel with strength/falloff), two 1-D passes with the follow-surface depth test and the
per-pixel rotation of the inner taps (seed 001 §3.3.4).

    ss_lighting        -> ss_diffuse, ss_depth, ...
    separable_blur     ss_diffuse -> "separable_diffuse"   (taps, strength, falloff, width, fov, ...)
    ss_combine         separable_diffuse -> lit
"""
from __future__ import annotations

import numpy as np

from skinviewer.passes.common import set_uniform
from skinviewer.passes.screen_space.blur import SeparableScreenBlur
from skinviewer.passes.screen_space.lighting import DIFFUSE, screen_size
from skinviewer.physics.separable import focal_px, separable_kernel

MAX_TAPS = 63
OUTPUT = "separable_diffuse"


class SeparableBlurPass(SeparableScreenBlur):
    program_name = "ss_separable_blur"

    def __init__(self):
        super().__init__("separable_blur", DIFFUSE, OUTPUT)

    def declare(self, r) -> bool:
        r.setting("separable")  # every field changes the kernel or the taps
        r.setting("camera.fov_y")
        screen_size(r)
        return True

    def set_uniforms(self, ec, prog) -> None:
        sp = ec.setting("separable")
        k, x = separable_kernel(int(sp.taps), sp.strength, sp.falloff)
        ks = np.zeros((MAX_TAPS, 3), np.float32)
        xs = np.zeros(MAX_TAPS, np.float32)
        ks[:len(k)], xs[:len(x)] = k, x
        if "u_k" in prog:
            prog["u_k"].write(ks.tobytes())
        if "u_x" in prog:
            prog["u_x"].write(xs.tobytes())
        set_uniform(prog, "u_taps", len(x))
        set_uniform(prog, "u_width_mm", float(sp.width_mm))
        set_uniform(prog, "u_focal", float(focal_px(ec.setting("camera.fov_y"), ec.setting("render.height"))))
        set_uniform(prog, "u_follow", 1 if sp.follow_surface else 0)
        set_uniform(prog, "u_follow_mm", float(sp.follow_surface_mm))
        set_uniform(prog, "u_rotate", 1 if sp.rotation and sp.rotation_fraction > 0 else 0)
        set_uniform(prog, "u_rot_fraction", float(sp.rotation_fraction))
