"""Issue 27: d'Eon's blurs shade only the island tiles when their seam fill dilates
(deon.skip_gutters with scene.seam_aware); the texels any reader reaches are bit-identical to the
whole-map draws (up to the denormal noise two identical renders show), and the lit image and the
final image are bit-identical."""
import numpy as np
import pytest
from helpers import small_settings

from skinviewer.ground.settings import with_values
from skinviewer.passes.deon import DILATE_RING
from skinviewer.passes.texture_space import read_gutter
from skinviewer.physics.diffusion import blur_resource


@pytest.mark.parametrize("gather,half", [(2.0, 0.0), (0.0, 0.0), (2.0, 2.0)],
                         ids=["summed-step", "all-separable", "half-size-wide-steps"])
def test_island_tiles_keep_every_reachable_texel_bit_identical(renderer, gather, half):
    s = small_settings("head", "deon", 64, **{"deon.irradiance_size": 512, "deon.skip_gutters": True,
                                              "deon.surface_gather_below_texels": gather,
                                              "deon.half_res_above_texels": half})
    rep = renderer.render(s, force=True)
    g = renderer.graph("deon")
    ran = [p.name for p in rep.passes if p.name.startswith("deon_blur_") and p.status == "ran"]
    assert ran, "some blur runs at these settings"
    objs = g.shape_state["gl_objects"]
    tiles = [objs[k] for k in objs if k[0] == "work_tiles" and k[3] == DILATE_RING]
    assert tiles and tiles[0][1] > 1, "the blurs drew a list of island tiles, not the whole map"
    names = ["lit", "image", "deon_diffuse"] + [blur_resource(int(p.rsplit("_", 1)[1])) for p in ran]
    a = {k: renderer.read(s, k) for k in names}
    gt = read_gutter(g.texture("gutter_512"))
    off = with_values(s, {"deon.skip_gutters": False})
    renderer.render(off, force=True)
    b = {k: renderer.read(off, k) for k in names}
    assert np.array_equal(a["lit"], b["lit"]) and np.array_equal(a["image"], b["image"])
    y, x = np.mgrid[0:512, 0:512]
    near = np.hypot(gt[..., 0] - x, gt[..., 1] - y) <= DILATE_RING
    assert 0.3 < near.mean() < 0.95
    # every texel a bilinear reader (deon_final, the transmitted light) reaches; llvmpipe leaves
    # ~1e-38 of noise in a few texels between two identical renders (denormals), so that is allowed
    halves = 0
    for k in names[2:]:
        m = a[k].shape[0]
        if m != 512:  # a half-size blur (deon.half_res_above_texels): the texels its readers reach there
            halves += 1
            gh = read_gutter(g.texture(f"gutter_{m}"))
            yh, xh = np.mgrid[0:m, 0:m]
            reach = np.hypot(gh[..., 0] - xh, gh[..., 1] - yh) <= DILATE_RING
        else:
            reach = near
        assert np.abs(a[k][reach] - b[k][reach]).max() <= 1e-30, k
    assert (halves > 0) == (half > 0), "wide steps are made at half size exactly when asked"
