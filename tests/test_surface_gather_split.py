"""The summed step split in two (issue 27): light-independent weights kept by the graph
(deon_gather_weights.frag, physics/surface_gather.gather_weights) and a light pass that sums with them
(deon_gather_sum.frag, gather_sum). The split sum is the one-pass sum (deon_surface_gather.frag,
surface_gather) within float rounding and the weights' half-float storage; a light move re-runs only
the light pass; what the weights read re-runs the weight pass."""
from __future__ import annotations

import numpy as np
import pytest
from helpers import first_gathered_step, small_settings

import skinviewer.passes.deon as deon_passes
from skinviewer.ground.settings import with_values
from skinviewer.passes.deon import GATHER_SURFACE, STRETCH, weights_resource
from skinviewer.passes.texture_space import gutter_resource
from skinviewer.physics.diffusion import IRRADIANCE, blur_plan_texels, blur_resource
from skinviewer.physics.surface_gather import (
    gather_sum,
    gather_weights,
    surface_gather,
    weight_count,
    weight_textures,
)


def _sheet(n: int = 24, seed: int = 3):
    """A wavy sheet with two zones, texels past a border, texels that are not surface, a shear."""
    rng = np.random.default_rng(seed)
    yy, xx = np.mgrid[0:n, 0:n].astype(float)
    S = np.zeros((n, n, 4))
    S[..., 0] = 0.3 * xx + rng.normal(0.0, 0.02, (n, n))
    S[..., 1] = 0.3 * yy
    S[..., 2] = 0.2 * np.sin(0.7 * xx)  # a fold: some texels nearer in 3D than along the surface
    S[..., 3] = rng.uniform(0.05, 0.12, (n, n))
    S[3:5, 3:9, 3] *= -1.0  # past a mesh border
    S[10, 10, 3] = 0.0
    S[20:, 20:, 3] = 0.0  # not surface
    Z = np.ones((n, n))
    Z[:, 15:] = 2.0
    st = np.stack([np.full((n, n), 1 / (0.3 * n)), np.full((n, n), 1 / (0.25 * n)), np.full((n, n), 0.2)], -1)
    E = rng.uniform(0.0, 1.0, (n, n, 4))
    E[:, :8, :3] = 0.0  # a shadow edge
    return E, S, Z, st


@pytest.mark.parametrize("blocks", [2, 3, 5])
def test_the_split_sum_is_the_one_pass_sum(blocks):
    """gather_sum over gather_weights is surface_gather to float64 rounding, every weight kept; with the
    weights stored as half floats (what the textures hold) within 5e-4 of the largest value."""
    E, S, Z, st = _sheet()
    v = 0.42 ** 2
    want = surface_gather(E, S, Z, st, v, blocks)
    W = gather_weights(S, Z, st, v, blocks, dtype=None)
    assert W.shape[-1] == 4 * weight_textures(blocks) >= weight_count(blocks)
    np.testing.assert_allclose(gather_sum(E, S, W, v, blocks), want, rtol=0, atol=1e-12)
    half = gather_sum(E, S, gather_weights(S, Z, st, v, blocks), v, blocks)
    err = np.abs(half - want).max() / np.abs(want).max()
    assert 0 < err < 5e-4  # rounded, not exact
    # the weights are the light's only geometry: a changed light changes nothing but the sum
    E2 = E[::-1].copy()
    np.testing.assert_allclose(gather_sum(E2, S, W, v, blocks), surface_gather(E2, S, Z, st, v, blocks), rtol=0, atol=1e-12)


def test_rings_past_lit_ring_take_the_light_at_the_area_mean_point():
    """gather_sum's lit_ring: the rings past it weigh their light as their thickness (the area's mean point).
    Under an even light (no texel past a border) the light's mean point is the area's, so nothing changes; at a
    shadow edge it does."""
    E, S, Z, st = _sheet()
    v = 0.42 ** 2
    W = gather_weights(S, Z, st, v, 3, dtype=None)
    every = gather_sum(E, S, W, v, 3)
    np.testing.assert_array_equal(gather_sum(E, S, W, v, 3, lit_ring=3), every)
    assert np.abs(gather_sum(E, S, W, v, 3, lit_ring=2) - every).max() > 1e-4  # the shadow edge at x = 8
    even = np.array(E)
    even[..., :3] = 0.7
    S = np.array(S)
    S[..., 3] = np.abs(S[..., 3])  # no texel past a border (its light is halved: not even)
    W = gather_weights(S, Z, st, v, 3, dtype=None)
    np.testing.assert_allclose(gather_sum(even, S, W, v, 3, lit_ring=1), gather_sum(even, S, W, v, 3), rtol=0, atol=1e-12)


def test_the_weights_are_normalised_to_the_centre_and_flag_what_is_not_summed():
    E, S, Z, st = _sheet()
    W = gather_weights(S, Z, st, 0.42 ** 2, 3, dtype=None)
    n = S.shape[0]
    yy, xx = np.mgrid[0:n, 0:n]
    centre = (2 + (yy & 1)) * 6 + 2 + (xx & 1)  # the texel itself among the 36 inner ones
    own = np.take_along_axis(W, centre[..., None], -1)[..., 0]
    surf = S[..., 3] != 0
    np.testing.assert_allclose(np.abs(own[surf]), 1.0, rtol=1e-12)
    assert np.all(own[S[..., 3] < 0] < 0)  # past a border: the sign says its light is shared
    blocks = W[..., 36:weight_count(3)]
    assert np.all((blocks == -1.0) | (blocks >= 0.0))
    assert (blocks[:, :14] == -1.0).any()  # blocks of the other zone are not summed


def _reach(renderer, s, step, n):
    from skinviewer.passes.deon import mean_texel_mm
    from skinviewer.physics.surface_gather import gather_blocks_for
    return gather_blocks_for(np.sqrt(step.increment) / mean_texel_mm(renderer.scene.gpu, n))


@pytest.mark.parametrize(("scene", "lit_ring"), [("head", None), ("head", 2), ("shadow-edge", None), ("shadow-edge", 2)])
def test_the_glsl_weights_and_sum_agree_with_their_numpy_twins(renderer, monkeypatch, scene, lit_ring):
    """At 256^2 without seams (the sum reads the irradiance itself): the kept weight textures are
    gather_weights of the surface the GPU made (island texels; half-float rounding of the two sides), and
    the summed blur is gather_sum of the irradiance with them. The head's step reaches 3 rings (every
    weight kept), the shadow edge's 4 (the fourth ring's weights computed in the sum: LIVE)."""
    monkeypatch.setattr(deon_passes, "LIT_RING", lit_ring)
    n = 256
    s = small_settings(scene, "deon", size=64, **{"deon.irradiance_size": n, "scene.seam_aware": False})
    renderer.render(s, force=True)  # a forced run reflects afresh: LIT_RING is a module constant
    g, texel, step = first_gathered_step(renderer, s, n)
    reach = _reach(renderer, s, step, n)
    assert reach == {"head": 3, "shadow-edge": 4}[scene]
    count = deon_passes.kept_textures(reach)
    kept = np.concatenate([g.read(weights_resource(step.index, t)).astype(np.float64) for t in range(count)], -1)
    gut = g.read(gutter_resource(n)).astype(np.float64)
    S = g.read(GATHER_SURFACE).astype(np.float64)
    island = (gut[..., 0] == np.arange(n)[None, :]) & (gut[..., 1] == np.arange(n)[:, None]) & (S[..., 3] != 0)
    assert island.sum() > n * n // 8
    want_w = gather_weights(S, np.abs(gut[..., 2]), g.read(STRETCH), step.increment, reach)
    k = weight_count(min(reach, 3))
    got_w, want_k = kept[island][:, :k], want_w[island][:, :k]
    # per texel, the weights' differences against the weight it sums (measured 8.7e-4 at most, 3.2e-4 mean:
    # half-float rounding, and the blocks' f32 mean points)
    err_w = np.abs(got_w - want_k).sum(1) / np.abs(np.where(want_k > -1.0, want_k, 0.0)).sum(1)
    assert err_w.max() < 2e-3 and err_w.mean() < 5e-4, (err_w.max(), err_w.mean())
    assert np.mean((got_w == -1.0) != (want_k == -1.0)) < 1e-4
    W = np.array(want_w)  # the live rings' weights as the twin computes them, the kept ones as the GPU holds them
    W[..., :kept.shape[-1]] = kept
    E = g.read(IRRADIANCE).astype(np.float64)
    got = g.read(blur_resource(step.index)).astype(np.float64)
    want = gather_sum(E, S, W, step.increment, reach, lit_ring=lit_ring)
    err = np.abs(got - want)[island].max(0) / np.maximum(np.abs(want[island]).max(0), 1e-12)
    assert np.all(err < 1e-4), err  # measured 2.3e-5: float32 sums and block moments


@pytest.mark.parametrize("scene", ["head", "shadow-edge"])
def test_the_split_sum_renders_the_one_pass_sum(renderer, monkeypatch, scene):
    """At 256^2 with seams (seam fill, island tiles; the shadow edge's open border and its fourth ring,
    computed in the sum) the summed blur and the lit image of the split sum are the one-pass sum's within
    the weights' half-float rounding."""
    from skinviewer.engine.renderer import Renderer
    s = small_settings(scene, "deon", size=64, **{"deon.irradiance_size": 256})
    g, texel, step = first_gathered_step(renderer, s, 256)
    assert weights_resource(step.index, 0) in g.resources()
    got = {k: g.read(k).astype(np.float64) for k in (blur_resource(step.index), "lit")}
    monkeypatch.setattr(deon_passes, "SPLIT_SUM", False)
    one = Renderer(renderer.ctx)
    try:
        one.render(s)
        g1 = one.graph("deon")
        assert not any(r.startswith("deon_gather_w") for r in g1.resources())
        for k, arr in got.items():
            want = g1.read(k).astype(np.float64)
            err = np.abs(arr - want).max() / np.abs(want).max()
            assert err < (1e-3 if k == "lit" else 3e-4), (k, err)
    finally:
        one.release()


def _ran(rep) -> set[str]:
    return {p.name for p in rep.passes if p.status == "ran"}


def test_a_light_move_keeps_the_weights_and_what_they_read_remakes_them(renderer):
    s = small_settings("head", "deon", size=48, **{"deon.irradiance_size": 256})
    renderer.render(s)
    texel = deon_passes.mean_texel_mm(renderer.scene.gpu, 256)
    plan = blur_plan_texels([x.variance for x in s.deon.gaussians], s.deon.reuse_irradiance_below_texels, texel,
                            s.deon.fold_below_texels)
    i = next(st for st in plan if not st.reused).index
    weights, blur = f"deon_gather_weights_{i}", f"deon_blur_{i}"
    assert weights_resource(i, 0) in renderer.graph("deon").resources()
    moved = _ran(renderer.render(with_values(s, {"lights.0.direction": [0.3, 0.2, 1.0]})))
    assert blur in moved and weights not in moved  # the light pass only
    renderer.render(s)
    v = s.deon.gaussians[i].variance
    for change in ({f"deon.gaussians.{i}.variance": v * 1.02},  # sigma of the step
                   {"deon.stretch": False},  # the sum's metric
                   {"scene.mm_per_unit": 1.1 * renderer.scene.gpu.mm_per_unit},  # the mesh's size
                   {"deon.irradiance_size": 512}):  # the map
        ran = _ran(renderer.render(with_values(s, change)))
        assert any(p.startswith("deon_gather_weights_") for p in ran), change
        renderer.render(s)


def test_the_shaders_list_the_taps_in_the_twins_order():
    """deon_gather_weights.frag and lib/gather_sum_taps.glsl (the taps of deon_gather_sum.frag and
    deon_gather_quad.frag) write one line per tap (its weight's index a literal): the 36 inner texels row by row, then the blocks ring by ring as block_offsets orders them,
    each ring under its GATHER_BLOCKS guard, up to GATHER_BLOCKS."""
    import re
    from pathlib import Path

    from skinviewer.physics.surface_gather import GATHER_BLOCKS, block_offsets
    root = Path(__file__).resolve().parents[1] / "shaders"
    inner = [(i, j, k) for k, (i, j) in enumerate((i, j) for j in range(-2, 4) for i in range(-2, 4))]
    blocks = [(i, j, 36 + k) for k, (i, j) in enumerate(block_offsets(GATHER_BLOCKS))]
    for name in ("deon_gather_weights.frag", "lib/gather_sum_taps.glsl"):
        text = (root / name).read_text()
        taps = [tuple(int(v) for v in m) for m in re.findall(r"^\s+INNER\((-?\d+), (-?\d+), (\d+)\)$", text, re.M)]
        assert taps == inner, name
        ring, got = 0, []
        for line in text.splitlines():
            m = re.match(r"#if GATHER_BLOCKS >= (\d+)$", line)
            if m:
                ring = int(m.group(1))
            m = re.match(r"\s+BLOCK\((-?\d+), (-?\d+), (\d+)\)$", line)
            if m:
                i, j, k = (int(v) for v in m.groups())
                assert max(abs(i), abs(j)) == ring, (name, line)
                got.append((i, j, k))
        assert got == blocks, name


def test_the_unit_count_is_never_queried_off_the_gl_thread():
    """The viewer's start-up warm-up reflects in a worker thread: moderngl caches ctx.info at its first
    read, so a read there cached zeros for the whole context ("too many textures" in every pass after).
    fragment_units reads ctx.info on the main thread only, else the cached value or 32."""
    import threading

    from skinviewer.passes.deon import fragment_units

    class Ctx:
        _info = None

        @property
        def info(self):
            raise AssertionError("ctx.info read off the GL thread")

    got = []
    t = threading.Thread(target=lambda: got.append(fragment_units(Ctx())))
    t.start()
    t.join()
    assert got == [32]
    ctx = Ctx()
    ctx._info = {"GL_MAX_TEXTURE_IMAGE_UNITS": 16}
    t = threading.Thread(target=lambda: got.append(fragment_units(ctx)))
    t.start()
    t.join()
    assert got == [32, 16]
