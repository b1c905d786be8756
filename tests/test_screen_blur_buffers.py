"""The screen-space blurs (shaders/ss_gauss_blur.frag, ss_separable_blur.frag) on uploaded buffers (issue 36:
the shader mutants that rendered scenes could not tell apart): skin next to brighter non-skin, and skin
next to brighter skin across a depth step. Jimenez 2009 replaces a tap off skin by the centre (seed 001
§3.2) and Jimenez 2015 also a tap across a depth step when following the surface (§3.3, [SEP]
SSSSBlurPS's lerp): the skin side of either edge must keep its own constant irradiance exactly, which the
blur would not if a single tap gathered from the other side (a check that it reaches: without the rule,
the same buffers bleed)."""
from __future__ import annotations

import numpy as np
import pytest
from burley_gpu import UploadPass, view_for

from skinviewer.ground.settings import Settings, with_values
from skinviewer.kernel.graph import FrameInputs, RenderGraph
from skinviewer.kernel.shaders import ShaderLibrary
from skinviewer.passes.screen_space.jimenez2009 import SsssBlurPass, blur_resource
from skinviewer.passes.screen_space.separable import OUTPUT as SEPARABLE_OUT
from skinviewer.passes.screen_space.separable import SeparableBlurPass

W, H = 48, 24
DARK, BRIGHT = 0.1, 1.0


def run_blur(ctx, technique, E, z, mask, **assign):
    if technique == "ssss":
        blur, out = SsssBlurPass(0), blur_resource(0)
    else:
        blur, out = SeparableBlurPass(), SEPARABLE_OUT
    up = UploadPass(E, z, mask)
    g = RenderGraph(ctx, ShaderLibrary(ctx), [up, blur], [out])
    try:
        s = with_values(Settings(), {"render.width": W, "render.height": H, "technique": technique, **assign})
        v = view_for(W, H)
        g.run(FrameInputs(settings=s, scene=None, scene_version=0, view=v, view_key=v.key()), force=True)
        return g.read(out)[..., :3].astype(np.float64)
    finally:
        g.release()


def halves(left, right):
    a = np.empty((H, W, 3))
    a[:, : W // 2], a[:, W // 2:] = left, right
    return a


# one Gaussian of sigma 2 mm (ssss) / the default separable kernel, 30 mm away (~2 px per mm): taps reach
# ~12 px, across the edge from the 12 columns beside it
WIDE = {"deon.gaussians": [{"variance": 4.0, "weights": [1.0, 1.0, 1.0]}], "ssss.beta": 0.0,
        "separable.rotation": False}


@pytest.mark.parametrize("technique", ["ssss", "separable"])
def test_skin_beside_non_skin_keeps_its_irradiance(gl_ctx, technique):
    """Left half skin (E = 0.1), right half non-skin (mask 0, E = 1), one depth: the skin keeps 0.1 and
    the non-skin stays as it was, bit for bit."""
    E = halves(DARK, BRIGHT)
    z = np.full((H, W), 30.0)
    mask = halves(1.0, 0.0)[..., 0]
    out = run_blur(gl_ctx, technique, E, z, mask, **WIDE)
    np.testing.assert_allclose(out[:, : W // 2], DARK, rtol=1e-5)  # float32 sums of normalised weights
    np.testing.assert_array_equal(out[:, W // 2:], np.float32(BRIGHT))
    # the same buffers all skin: the blur does reach across (the test above is not vacuous)
    both = run_blur(gl_ctx, technique, E, z, np.ones((H, W)), **WIDE)
    assert both[:, W // 2 - 1, 0].min() > DARK + 0.05


def test_separable_follows_the_surface_across_a_depth_step(gl_ctx):
    """All skin; left half 30 mm away (E = 0.1), right half 45 mm (E = 1). With follow_surface and a
    threshold far below the 15 mm step, every tap across the step takes the centre's colour: each half
    keeps its constant. Without it the near half bleeds."""
    E = halves(DARK, BRIGHT)
    z = halves(30.0, 45.0)[..., 0]
    mask = np.ones((H, W))
    follow = {**WIDE, "separable.follow_surface": True, "separable.follow_surface_mm": 0.5}
    out = run_blur(gl_ctx, "separable", E, z, mask, **follow)
    np.testing.assert_allclose(out[:, : W // 2], DARK, rtol=1e-5)
    np.testing.assert_allclose(out[:, W // 2:], BRIGHT, rtol=1e-5)
    free = run_blur(gl_ctx, "separable", E, z, mask, **{**follow, "separable.follow_surface": False})
    assert free[:, W // 2 - 1, 0].min() > DARK + 0.05
