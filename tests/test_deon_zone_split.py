"""Issue 27: a separable d'Eon blur draws the island tiles where no tap can reach another UV island
zone with a variant compiled without the zone checks (passes/deon.zone_split, deon_blur.frag
NO_ZONE_CHECKS), and its seam fill's tiles with no texel across a seam or past a border as a plain
copy (passes/deon.seam_split, seam_fill.frag NO_SEAM): llvmpipe pays a branch's work under a mask on
every texel otherwise. Those tiles hold no texel the removed code would change, so the blurs, the
diffuse sum and the image are the same as with every tile checked and filled."""
import numpy as np
import pytest
from helpers import small_settings

import skinviewer.passes.deon as deon_passes
from skinviewer.passes.deon import DILATE_RING
from skinviewer.passes.texture_space import TILE, read_gutter
from skinviewer.physics.diffusion import blur_resource


@pytest.mark.parametrize("half", [0.0, 2.0], ids=["full-size", "half-size-wide-steps"])
def test_zone_free_tiles_give_the_same_blurs(renderer, monkeypatch, half):
    s = small_settings("head", "deon", 64, **{"deon.irradiance_size": 512, "deon.skip_gutters": True,
                                              "deon.surface_gather_below_texels": 0.0,
                                              "deon.half_res_above_texels": half})
    rep = renderer.render(s, force=True)
    sep = [p for p in rep.passes if p.name.startswith("deon_blur_") and p.status == "ran"]
    assert sep and sum(p.figures.get("zone_free_rects", 0) for p in sep) > 0, "some tiles are drawn unchecked"
    names = ["lit", "image", "deon_diffuse"] + [blur_resource(int(p.name.rsplit("_", 1)[1])) for p in sep]
    a = {k: renderer.read(s, k) for k in names}
    objs = renderer.graph("deon").shape_state["gl_objects"]
    assert any(k[0] == "seam_split" and k[-1] == "plain" and objs[k] is not None for k in objs), \
        "some fill tiles are plain copies"
    monkeypatch.setattr(deon_passes, "zone_split", lambda *args, **kw: None)  # every tile checked
    monkeypatch.setattr(deon_passes, "seam_split", lambda *args, **kw: None)  # every tile seam-filled
    renderer.render(s, force=True)
    b = {k: renderer.read(s, k) for k in names}
    assert np.array_equal(a["lit"], b["lit"]) and np.array_equal(a["image"], b["image"])
    # every texel a reader reaches (within DILATE_RING of an island: texels beyond keep stale contents),
    # llvmpipe's run-to-run denormal noise (~1e-38) allowed, as in test_deon_blur_floor
    g = renderer.graph("deon")
    for k in names[2:]:
        m = a[k].shape[0]
        gt = read_gutter(g.texture(f"gutter_{m}"))
        y, x = np.mgrid[0:m, 0:m]
        reach = np.hypot(gt[..., 0] - x, gt[..., 1] - y) <= DILATE_RING
        assert np.abs(a[k][reach] - b[k][reach]).max() <= 1e-30, k


def _split_tiles(renderer, split: str, part: str):
    """d'Eon at 256² maps, every blur full size: its graph, gl_objects and the keys of ``split``'s
    ``part`` tile lists (zone_split free / seam_split plain)."""
    s = small_settings("head", "deon", 64, **{"deon.irradiance_size": 256, "deon.skip_gutters": True,
                                              "deon.surface_gather_below_texels": 0.0,
                                              "deon.half_res_above_texels": 0.0})
    renderer.render(s, force=True)
    g = renderer.graph("deon")
    objs = g.shape_state["gl_objects"]
    keys = [k for k in objs if k[0] == split and k[-1] == part and objs[k] is not None]
    assert keys, f"no {split} {part} tiles"
    return g, objs, keys


def test_free_tiles_hold_no_texel_near_another_zone(renderer):
    """zone_split's free tiles: every texel's island texel lies at least `reach` texels from another
    zone (the gutter map's A), so deon_blur's ISLAND_CHECK is false there; the checked ones have one."""
    g, objs, keys = _split_tiles(renderer, "zone_split", "free")
    gt = read_gutter(g.texture(f"gutter_{keys[0][2]}"))
    n = gt.shape[0]
    sx = np.clip((gt[..., 0] + 0.5).astype(int), 0, n - 1)
    sy = np.clip((gt[..., 1] + 0.5).astype(int), 0, n - 1)
    border = gt[sy, sx, 3]  # texels from the island texel each texel is computed at to another zone
    for key in keys:
        reach = key[4]
        tex, count, edge = objs[key]
        assert edge == TILE
        boxes = np.frombuffer(tex.read(), np.float32).reshape(count, 4).astype(int)
        for x0, y0, w, h in boxes:
            assert (border[y0:y0 + h, x0:x0 + w] >= reach).all()
        checked = objs[key[:-1] + ("checked",)]
        if checked is not None:
            cb = np.frombuffer(checked[0].read(), np.float32).reshape(checked[1], 4).astype(int)
            assert not any((border[y0:y0 + h, x0:x0 + w] >= reach).all() for x0, y0, w, h in cb
                           if w == TILE and h == TILE)  # a single checked tile has a texel near a border


def test_plain_fill_tiles_hold_no_seam_texel(renderer):
    """seam_split's plain tiles: no texel in them lies across a seam or past a border (the seam map's
    B is 0), so seam_fill's plain copy is what the full fill gives there; the seam tiles each have one."""
    g, objs, keys = _split_tiles(renderer, "seam_split", "plain")
    for key in keys:
        n = key[2]
        b = g.texture(f"seam_{n}")
        seam_b = np.frombuffer(b.read(), np.float32).reshape(n, n, b.components)[..., 2]
        tex, count, _ = objs[key]
        for x0, y0, w, h in np.frombuffer(tex.read(), np.float32).reshape(count, 4).astype(int):
            assert (seam_b[y0:y0 + h, x0:x0 + w] < 0.5).all()
        seam = objs[key[:-1] + ("seam",)]
        if seam is not None:
            for x0, y0, w, h in np.frombuffer(seam[0].read(), np.float32).reshape(seam[1], 4).astype(int):
                if w == TILE and h == TILE:
                    assert (seam_b[y0:y0 + h, x0:x0 + w] > 0.5).any()
