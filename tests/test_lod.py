"""Mesh levels of detail (issue 14: a head under 1 % of the screen costs a fraction of a close-up):
scene/lod.py builds them, passes/rules.mesh_lod picks one from the screen coverage, the passes that
draw the mesh say so, and the far image stays as close to a supersampled one as the full mesh's."""
from __future__ import annotations

import numpy as np
import pytest
from helpers import small_settings

from skinviewer.ground.settings import with_values
from skinviewer.passes import rules
from skinviewer.scene.head import default_head
from skinviewer.scene.lod import decimate, level_targets, surviving_vertex


@pytest.fixture(scope="module")
def head():
    return default_head(0)


def _border_vertices(indices: np.ndarray) -> np.ndarray:
    e = np.sort(np.concatenate([indices[:, [0, 1]], indices[:, [1, 2]], indices[:, [2, 0]]]), axis=1)
    uniq, count = np.unique(e, axis=0, return_counts=True)
    return np.unique(uniq[count == 1])


def test_levels_keep_vertices_uv_seams_and_shape(head):
    targets = level_targets(len(head.indices))
    assert len(targets) >= 2 and all(b * 4 <= a for a, b in zip(targets, targets[1:]))
    key = {tuple(r): i for i, r in enumerate(np.hstack([head.positions, head.uvs]))}
    border = {tuple(r) for r in np.hstack([head.positions, head.uvs])[_border_vertices(head.indices)]}
    for t in targets[1:]:
        lod = decimate(head, t)
        assert abs(len(lod.indices) - t) <= 0.02 * t
        rows = [tuple(r) for r in np.hstack([lod.positions, lod.uvs])]
        # every vertex is a vertex of the mesh, with its own position and UV (texture space unwraps
        # a level where the full mesh puts those points)
        idx = np.array([key[r] for r in rows])
        assert np.array_equal(lod.normals, head.normals[idx]) and np.array_equal(lod.tangents, head.tangents[idx])
        # UV seams and open borders are kept: every border vertex survives
        assert border <= set(rows)
        # the UV islands keep their area (no triangle folds away a piece of the atlas)
        def uv_area(m):
            a, b, c = (m.uvs[m.indices[:, k]] for k in range(3))
            return 0.5 * np.abs((b - a)[:, 0] * (c - a)[:, 1] - (b - a)[:, 1] * (c - a)[:, 0]).sum()
        assert uv_area(lod) == pytest.approx(uv_area(head), rel=0.03)


def test_surviving_vertex_follows_chains():
    # 3 -> 2, then 2 -> 0: 3 ends in 0; 1 survives
    assert surviving_vertex(4, np.array([[2, 3], [0, 2]])).tolist() == [0, 1, 0, 0]


def test_rule_picks_a_level_from_coverage_with_hysteresis(renderer):
    s = small_settings("head", "phong", 256, **{"scene.head_detail": 1})  # 61k triangles: 3 levels
    renderer.render(s)
    gpu = renderer.scene.gpu
    d0 = float(np.linalg.norm(renderer.view(s).eye - gpu.center))

    def lod(x, st):  # the rule on the frame's view the renderer builds for x
        return rules.mesh_lod(x, renderer.frame_view(x), st)
    state: dict = {}
    assert lod(s, state) == (0, "")  # a close-up keeps every triangle
    far = with_values(s, {"camera.distance": d0 * 12})
    level, why = lod(far, {})
    assert level == len(gpu.lod_triangles) - 1 and "from screen coverage" in why
    assert lod(with_values(far, {"render.mesh_lod": "full"}), {}) == (0, "")
    # find the distance where level 1 begins, then step just across it and back: no flip-flop
    lo, hi = 1.0, 12.0
    for _ in range(30):
        mid = 0.5 * (lo + hi)
        if lod(with_values(s, {"camera.distance": d0 * mid}), {})[0] >= 1:
            hi = mid
        else:
            lo = mid
    state = {}
    assert lod(with_values(s, {"camera.distance": d0 * hi * 1.02}), state)[0] == 1
    assert lod(with_values(s, {"camera.distance": d0 * lo * 0.98}), state)[0] == 1  # held
    assert lod(with_values(s, {"camera.distance": d0 * lo * 0.6}), state)[0] == 0


@pytest.mark.parametrize("technique", ["phong", "deon"])
def test_far_frame_draws_a_level_as_close_to_supersampled_as_the_full_mesh(renderer, technique):
    n = 128
    s = small_settings("head", technique, n, **{"render.tone_map": "linear", "deon.irradiance_size_mode": "auto",
                                                "shadow.map_size_mode": "auto", "scene.head_detail": 1})
    renderer.render(s)
    d0 = float(np.linalg.norm(renderer.view(s).eye - renderer.scene.gpu.center))
    far = with_values(s, {"camera.distance": d0 * 8})  # the head ~14 px across: LOD 2
    img = {}
    for mode in ("full", "auto"):
        sm = with_values(far, {"render.mesh_lod": mode})
        rep = renderer.render(sm)
        drew = [p for p in rep.passes if p.status == "ran" and p.draws and "mesh LOD" in p.reason]
        if mode == "auto":
            # d'Eon's mesh draw from the view: deon_final, or its view pass where the final pass is split
            final = {"phong": {"phong"}, "deon": {"deon_final", "deon_final_view"}}[technique]
            assert final & {p.name for p in drew} and "shadow_map_0" in [p.name for p in drew]
        else:
            assert not drew
        img[mode] = renderer.read(sm, "image")[..., :3].astype(np.float64)
    k = 8  # the reference: the full mesh at 8 x 8 samples per pixel
    big = with_values(far, {"render.mesh_lod": "full", "render.width": n * k, "render.height": n * k})
    renderer.render(big)
    ref = renderer.read(big, "image")[..., :3].astype(np.float64).reshape(n, k, n, k, 3).mean((1, 3))
    mask = ref.max(-1) > 0.07
    assert mask.sum() > 30
    err = {m: np.sqrt(((img[m] - ref)[mask] ** 2).mean()) / ref[mask].mean() for m in img}
    assert err["auto"] <= err["full"] * 1.15 + 0.01, err
    # no energy from nowhere: the head's mean colour within 3 % of the full mesh's
    np.testing.assert_allclose(img["auto"][mask].mean(0), img["full"][mask].mean(0), rtol=0.03)


def test_close_up_is_bit_identical_with_lod_on(renderer):
    s = small_settings("head", "deon", 96)
    renderer.render(with_values(s, {"render.mesh_lod": "full"}))
    a = renderer.read(s, "image")
    rep = renderer.render(with_values(s, {"render.mesh_lod": "auto"}))
    assert not any("mesh LOD" in p.reason for p in rep.passes)
    assert np.array_equal(a, renderer.read(s, "image"))
