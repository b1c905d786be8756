"""Issue 27 ("Also asked"): d'Eon's wide blur steps on a half-size map (deon.half_res_above_texels) and
the blurs' island tiles drawn as merged rectangles (texture_space.tile_rects)."""
import numpy as np
import pytest
from helpers import small_settings

from skinviewer.ground.settings import with_values
from skinviewer.passes.texture_space import read_gutter, tile_rects


def test_tile_rects_cover_exactly_the_tiles():
    rng = np.random.default_rng(7)
    for _ in range(300):
        tiles = rng.random((int(rng.integers(1, 14)), int(rng.integers(1, 14)))) < rng.random()
        count = np.zeros(tiles.shape, int)
        for x, y, w, h in tile_rects(tiles):
            assert w > 0 and h > 0
            count[y:y + h, x:x + w] += 1
        assert np.array_equal(count, tiles.astype(int))  # every tile once, nothing else
    # runs merge along a row and down the rows they span alike
    assert tile_rects(np.ones((5, 7), bool)).tolist() == [[0, 0, 7, 5]]


def _covered(g: np.ndarray) -> np.ndarray:
    m = g.shape[0]
    y, x = np.mgrid[0:m, 0:m]
    return (g[..., 0] == x) & (g[..., 1] == y)


def test_half_size_wide_step_matches_the_full_size_blur(renderer):
    """At 512^2 maps the widest step (sigma ~2.6 mean texels on the head) is made at 256^2: its texture is
    half the side, it agrees with the full-size blur filtered down to within a few percent on every island
    texel, and the image moves by less than an 8-bit level on average."""
    base = small_settings("head", "deon", 96, **{"deon.irradiance_size": 512, "deon.half_res_above_texels": 0.0})
    half = with_values(base, {"deon.half_res_above_texels": 2.0})
    renderer.render(base, force=True)
    full_img = renderer.read(base, "image")
    full = {k: renderer.read(base, k) for k in ("blur_5", "deon_diffuse")}
    rep = renderer.render(half, force=True)
    ran = {p.name: p for p in rep.passes if p.status == "ran"}
    assert "deon_blur_5" in ran
    b5 = renderer.read(half, "blur_5")
    assert b5.shape[:2] == (256, 256) and full["blur_5"].shape[:2] == (512, 512)
    g = renderer.graph("deon")
    cov = _covered(read_gutter(g.texture("gutter_256")))
    # the full-size blur at the half-size texel centres (the corners of 2 x 2 full-size texels)
    down = full["blur_5"].reshape(256, 2, 256, 2, -1).mean(axis=(1, 3))
    rgb = lambda a: a[..., :3][cov]  # noqa: E731
    rel = np.sqrt(np.mean((rgb(b5) - rgb(down)) ** 2)) / np.sqrt(np.mean(rgb(down) ** 2))
    assert rel < 0.05, rel
    # the diffuse sum reads it filtered up (deon_combine HALF_MASK): close to the full-size sum
    d = renderer.read(half, "deon_diffuse")
    cov_full = _covered(read_gutter(g.texture("gutter_512")))
    rel_d = np.sqrt(np.mean((d[..., :3][cov_full] - full["deon_diffuse"][..., :3][cov_full]) ** 2)) / np.sqrt(
        np.mean(full["deon_diffuse"][..., :3][cov_full] ** 2))
    assert rel_d < 0.02, rel_d
    img = renderer.read(half, "image")
    assert np.abs(img[..., :3].astype(float) - full_img[..., :3].astype(float)).mean() < 1.0 / 255.0


def test_open_border_keeps_full_size_blurs(renderer):
    """A mesh with an open border reflects the light there (deon.open_border = reflect, its border frame is
    full size): every blur stays full size whatever deon.half_res_above_texels asks."""
    s = small_settings("stretch-plane", "deon", 64, **{"deon.irradiance_size": 512, "deon.half_res_above_texels": 0.5})
    rep = renderer.render(s, force=True)
    ran = [p.name for p in rep.passes if p.name.startswith("deon_blur_") and p.status == "ran"
           and "summed" not in (p.note or "")]
    assert ran
    for name in ran:
        assert renderer.read(s, "blur_" + name.rsplit("_", 1)[1]).shape[:2] == (512, 512)


def test_half_size_increment_keeps_the_variance_readers_see():
    """physics.diffusion.half_size_increment: the coarser grid's interpolation variance comes off the
    step's own (the first half-size step also carries the readers' filtering up for the chain)."""
    from skinviewer.physics.diffusion import (
        HALF_DOWN_EXTRA,
        HALF_PASS_EXTRA,
        HALF_READ_EXTRA,
        half_size_increment,
    )
    t = 0.44
    assert half_size_increment(5.42, t, first=False) == pytest.approx(5.42 - HALF_PASS_EXTRA * t * t)
    first = half_size_increment(1.42, t, first=True)
    assert first == pytest.approx(1.42 - (HALF_PASS_EXTRA + HALF_READ_EXTRA + HALF_DOWN_EXTRA) * t * t)
    assert half_size_increment(0.01, t, first=True) == 0.0  # never negative
    # a tent filter read at quarter offsets: 3/16 of a coarse texel^2 = 0.75 fine texel^2 (the constant's source)
    f = 0.25
    assert HALF_READ_EXTRA == pytest.approx(f * (1 - f) * 4)
