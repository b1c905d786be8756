"""Jimenez et al. 2009, screen-space perceptual rendering of skin (seed 001 §3.2, eq. 3.2; spec §3):
per Gaussian i of ``deon.gaussians`` (at most ``ssss.gaussians``), blur_i = blur_(i-1) x G(v_i -
v_(i-1)) separably (incremental, seed 000 eq. 24), tap spacing from depth and depth gradient;
then ssss_diffuse = sum_i w_i blur_i.

    ss_lighting   -> ss_diffuse, ss_depth, ...
    ssss_blur_i   ss_diffuse | ssss_blur_(i-1) -> "ssss_blur_i"   (v_0..v_i, alpha, beta, taps, fov)
    ssss_sum      ssss_blur_* -> "ssss_diffuse"                   (weights)
    ss_combine    ssss_diffuse -> lit
"""
from __future__ import annotations

import numpy as np

from skinviewer.ground.constants import MAX_GAUSSIANS
from skinviewer.kernel.pass_api import Pass, Reflection, declare, whole
from skinviewer.passes.screen_space.blur import SeparableScreenBlur, blur_spec
from skinviewer.passes.screen_space.lighting import DIFFUSE, screen_size
from skinviewer.physics.separable import focal_px, gaussian_taps, incremental_sigmas, limit_gaussians

SUM = "ssss_diffuse"


def blur_resource(i: int) -> str:
    return f"ssss_blur_{i}"


def gaussian_count(r) -> int:
    return min(len(r.peeked.deon.gaussians), r.peeked.ssss.gaussians, MAX_GAUSSIANS)


class SsssBlurPass(SeparableScreenBlur):
    """blur_i: the increment sqrt(v_i - v_(i-1)), H then V, eq. 3.2 stretch."""

    def __init__(self, i: int):
        super().__init__(f"ssss_blur_{i}", DIFFUSE if i == 0 else blur_resource(i - 1), blur_resource(i))
        self.i = i

    def declare(self, r: Reflection) -> bool:
        if gaussian_count(r) <= self.i:
            return False
        declare(r.settings.ssss.gaussians)
        vs = [r.settings.deon.gaussians[k].variance for k in range(self.i + 1)]
        p = r.settings.ssss
        declare(p.alpha, p.beta)
        taps = int(p.taps)
        # this step's increment sqrt(v_i - v_(i-1)) (seed 000 eq. 24); the focal length in pixels (eq. 3.2)
        r.plan(taps=taps, sigma_mm=float(incremental_sigmas(vs)[self.i]),
               focal=float(focal_px(r.settings.camera.fov_y, screen_size(r)[1])))
        r.program("ss_gauss_blur", TAPS=taps)
        return True

    def program(self, ec):
        return ec.program("ss_gauss_blur")

    def set_uniforms(self, ec, prog) -> None:
        x, w = gaussian_taps(ec.plan.taps)
        p = ec.settings.ssss
        ec.uniforms(prog, u_x=x, u_w=w, u_sigma_mm=ec.plan.sigma_mm, u_alpha=float(p.alpha), u_beta=float(p.beta),
                    u_focal=ec.plan.focal)


class SsssSumPass(Pass):
    """ssss_diffuse = sum_i w_i blur_i (the weights of Gaussians dropped by ssss.gaussians go to
    the widest kept one)."""
    name = "ssss_sum"
    uses_scene = False
    tileable = True  # in row bands under the viewer's frame budget (issue 27)

    def reflect(self, r: Reflection) -> None:
        n = gaussian_count(r)
        declare(r.settings.deon.gaussians)
        declare(r.settings.ssss.gaussians)
        r.input(DIFFUSE)
        blurs = tuple(blur_resource(i) for i in range(n))
        for res in blurs:
            r.input(res)
        r.plan(blurs=blurs)
        r.program("ss_gauss_sum")
        r.output(SUM, blur_spec(r))

    def execute(self, ec) -> None:
        prog = ec.program("ss_gauss_sum")
        gs = [(g.variance, g.weights) for g in whole(ec.settings.deon.gaussians)]
        kept = limit_gaussians(gs, int(ec.settings.ssss.gaussians))[:MAX_GAUSSIANS]
        w = np.zeros((MAX_GAUSSIANS, 3), np.float32)
        for i, (_, wt) in enumerate(kept):
            w[i] = wt
        ec.uniforms(prog, u_w=w, u_count=len(kept))
        ec.bind(prog, "diffuse", DIFFUSE)
        for i, res in enumerate(ec.plan.blurs[:len(kept)]):
            ec.bind(prog, f"blur{i}", res)
        with ec.band():
            ec.draw_fullscreen(prog, SUM)
