"""Issue 27: long passes in row bands across frames, and cancelling them (the graph stops between
passes and between bands of a pass under a frame time budget, its cache consistent)."""
from __future__ import annotations

import numpy as np
import pytest

from skinviewer.ground.settings import with_values
from tests.helpers import small_settings

GATHER = "deon_blur_5"  # at 256^2 maps on the head the last blur step is summed over the surface (tileable)
OUT = "blur_5"  # its output


def ftz(a: np.ndarray) -> np.ndarray:
    """Values under 1e-30 flushed to zero: llvmpipe's own whole-draw renders of the same input differ
    there from run to run (an intermediate flushed as subnormal or not; e.g. 1.9488e-36 vs
    1.9487e-36), so bit for bit means bit for bit above that."""
    return np.where(np.abs(a) < 1e-30, np.float32(0.0), a)


def same(a: np.ndarray, b: np.ndarray) -> bool:
    return np.array_equal(ftz(a), ftz(b))


def deon(**kw):
    return small_settings("head", "deon", size=64, **kw)


def settle(renderer, s, budget_ms=1e-6, max_frames=4000):
    """Render ``s`` under ``budget_ms`` until a frame completes; the reports of every call."""
    reports = []
    for _ in range(max_frames):
        reports.append(renderer.render(s, budget_ms=budget_ms))
        if reports[-1].complete:
            return reports
    raise AssertionError("the frame never completed")


def test_the_summed_step_is_tileable_and_bands_are_bit_identical(renderer, gl_ctx):
    s = deon()
    renderer.render(s)
    g = renderer.graph("deon")
    assert next(p for p in g.passes if p.name == GATHER).tileable
    whole = {res: g.read(res).copy() for res in (OUT, "deon_irradiance", "image")}
    s2 = with_values(s, {"lights.0.direction": [0.3, 0.2, 1.0]})
    renderer.render(s2)
    ref2 = {res: g.read(res).copy() for res in whole}
    # back to s under a tiny budget: the irradiance and the summed step each in bands, over frames
    reports = settle(renderer, s)
    bands = [p for rep in reports for p in rep.passes if p.name == GATHER and "band" in p.reason]
    assert bands, "the summed step was never split"
    assert any(p.status == "deferred" for p in bands)
    for name in ("deon_irradiance", "deon_final"):  # the view pass too: its mesh draw in row bands
        assert any(p.status == "deferred" and "band" in p.reason for rep in reports for p in rep.passes
                   if p.name == name), name
    for res, arr in whole.items():
        assert same(g.read(res), arr), res  # bit for bit what one whole draw gives
    # and the same for s2 (its keys were dropped while s's bands ran: no stale hit)
    settle(renderer, s2)
    for res, arr in ref2.items():
        assert same(g.read(res), arr), res


def test_a_pass_cancelled_mid_way_is_never_cached_under_a_stale_key(renderer):
    s = deon()
    renderer.render(s)
    g = renderer.graph("deon")
    image_s = g.read("image").copy()
    blur_s = g.read(OUT).copy()
    s2 = with_values(s, {"lights.0.direction": [-0.4, 0.1, 1.0]})
    # start s2 and stop inside the summed step's bands
    for _ in range(2000):
        rep = renderer.render(s2, budget_ms=1e-6)
        if GATHER in g.in_progress:
            break
    assert GATHER in g.in_progress and g.in_progress[GATHER][0] < g.in_progress[GATHER][1]
    assert GATHER not in g._keys  # its output is half overwritten: under no key
    # the user goes back to s before it finished: the bands of s2 are abandoned...
    rep = renderer.render(s, budget_ms=None)
    assert GATHER in g.cancelled and not g.in_progress
    # ...and the summed step re-ran for s rather than being found cached with s2's half-written texels
    assert next(p for p in rep.passes if p.name == GATHER).status == "ran"
    assert same(g.read(OUT), blur_s)
    assert np.array_equal(g.read("image"), image_s)


def test_a_deferred_band_keeps_the_previous_image_and_downstream_waits(renderer):
    s = deon()
    renderer.render(s)
    g = renderer.graph("deon")
    before = g.read("image").copy()
    s2 = with_values(s, {"lights.0.intensity": 2.5})
    seen_partial = False
    for _ in range(4000):
        rep = renderer.render(s2, budget_ms=1e-6)
        if rep.complete:
            break
        if g.in_progress:
            seen_partial = True
            waits = [p for p in rep.passes if p.reason.startswith("waits for")]
            assert all(p.status == "deferred" for p in waits)
        assert np.array_equal(g.read("image"), before)  # never a half-made image on screen
    assert seen_partial and rep.complete
    assert not np.array_equal(g.read("image"), before)


def test_separable_blurs_run_draw_by_draw_in_bands_bit_identically(renderer):
    """A separable d'Eon blur (H then V per sub-step, seam fills between) under a budget: each draw
    in row bands, complete before the next starts; the result is the whole pass's."""
    s = deon(**{"deon.surface_gather_below_texels": 0.0})
    renderer.render(s)
    g = renderer.graph("deon")
    want = g.read("blur_5").copy()
    renderer.render(with_values(s, {"lights.0.direction": [0.3, -0.2, 1.0]}))
    reports = settle(renderer, s)
    assert any(p.name == "deon_blur_5" and p.status == "deferred" and "band" in p.reason
               for rep in reports for p in rep.passes)
    assert same(g.read("blur_5"), want)


def test_without_a_budget_nothing_is_banded(renderer):
    """`skinviewer render` and `bench` (no budget) run every pass whole, as before."""
    rep = renderer.render(deon(), force=True)
    assert rep.complete and not any("band" in p.reason for p in rep.passes)
    assert not renderer.graph("deon").in_progress


def test_the_summed_steps_reach_follows_sigma():
    """physics/surface_gather.gather_blocks_for: 3.5 sigma at 1.6 x the mean texel density, 2..5 blocks;
    on a flat sheet the shorter reach leaves out under 1 % of the weight the old fixed reach summed."""
    from skinviewer.physics.surface_gather import GATHER_BLOCKS, gather_blocks_for, surface_gather
    reach = [gather_blocks_for(x) for x in np.linspace(0.0, 4.0, 41)]
    assert reach == sorted(reach) and min(reach) == 2 and max(reach) == GATHER_BLOCKS
    assert gather_blocks_for(1.4) == 3  # the default head's gathered step at 1024^2 (issue 27: it was 5)
    for x in (0.5, 1.0, 1.4, 2.0):  # the reach covers 3.5 sigma at 1.6 x the mean density (capped at 5)
        assert 2 * gather_blocks_for(x) + 2 >= min(3.5 * 1.6 * x, 2 * GATHER_BLOCKS + 2)
    # a flat 48 x 48 sheet, 1 mm texels, a point of light in the middle: sigma 1.4 texels
    n = 48
    yy, xx = np.mgrid[0:n, 0:n].astype(np.float64)
    surface = np.stack([xx, yy, np.zeros_like(xx), np.ones_like(xx)], -1)
    E = np.zeros((n, n, 4))
    E[24, 24, :3] = 1.0
    E[..., 3] = 1.0
    zone = np.ones((n, n))
    stretch = np.stack([np.full((n, n), 1.0 / n), np.full((n, n), 1.0 / n), np.zeros((n, n))], -1)
    full = surface_gather(E, surface, zone, stretch, 1.4 ** 2, GATHER_BLOCKS)
    short = surface_gather(E, surface, zone, stretch, 1.4 ** 2, gather_blocks_for(1.4))
    assert abs(short[..., 0].sum() - full[..., 0].sum()) < 0.01 * full[..., 0].sum()
    assert np.abs(short[..., 0] - full[..., 0]).max() < 0.01 * full[..., 0].max()


# Passes that re-run on a light move and are not split into bands, with why each is short on any
# machine (a pass missing here and not tileable fails the next test: a new long pass must be banded).
UNSPLIT = {
    "deon_tsm": "one texture-space draw writing a few floats per texel",
    "deon_combine": "a per-texel weighted sum of the blurs (a few fetches)",
    "output": "the tone map: one fetch per pixel",
    "burley_count": "a row reduction of the sample-count statistics (a few hundred rows)",
    "burley_temporal": "one fetch of this frame and the history per pixel",
    "deon_gather_surface": "numpy upload of the surface-gather table (cached per mesh; re-keyed on σ only)",
}


@pytest.mark.parametrize("technique", ["phong", "gosselin", "deon", "ssss", "separable", "burley", "burley2", "penner"])
def test_every_long_pass_is_banded_and_bands_are_bit_identical(renderer, technique):
    """Under the viewer's frame budget every pass a light move re-runs is split into row bands
    (those in UNSPLIT excepted, each short by construction), and the frame made band by band over
    many calls is the whole frame's, bit for bit."""
    s = small_settings("head", technique, size=64)
    renderer.render(s)
    g = renderer.graph(technique)
    whole = {res: g.read(res).copy() for res in ("lit", "image")}
    s2 = with_values(s, {"lights.0.direction": [0.3, 0.2, 1.0]})
    ran = {p.name for p in renderer.render(s2).passes if p.status == "ran"}
    tileable = {p.name for p in g.passes if p.tileable}
    assert not ran - tileable - set(UNSPLIT), f"long passes that are not split: {sorted(ran - tileable - set(UNSPLIT))}"
    reports = settle(renderer, s)  # back to s under a tiny budget: every tileable pass in bands
    banded = {p.name for rep in reports for p in rep.passes if p.status == "deferred" and "band" in p.reason}
    assert (ran & tileable) <= banded, sorted((ran & tileable) - banded)
    for res, arr in whole.items():
        assert same(g.read(res), arr), res


def test_a_pass_s_expected_cost_follows_its_output_pixels(renderer):
    """A governed preview renders the view pass at a quarter of the view, then the whole view: the
    bands of the whole view are sized from the quarter-view cost times the pixels (not the quarter
    view's cost itself, which made the first band of the whole view one long frame)."""
    s = small_settings("head", "phong", size=64)
    renderer.render(s)
    g = renderer.graph("phong")
    p = next(p for p in g.passes if p.name == "phong")
    ms = g._last_ms["phong"]
    big = with_values(s, {"render.width": 128, "render.height": 128})
    r = g._reflect_all(big, renderer.scene.gpu)["phong"]
    assert g._expected_ms(p, r) == pytest.approx(4.0 * ms)
    assert g._tile_count(p, r, budget_ms=ms) == min(8, 128)  # 4 ms-units of work in bands of half a budget


def test_a_band_draws_only_the_triangles_that_reach_its_rows(renderer, monkeypatch):
    """A view pass in n bands does not transform the whole mesh n times: each band draws the
    triangles whose window rows reach it (GpuServices.band_vao), so over all bands the mesh is
    drawn little more than once (triangles straddling a band edge are drawn in both)."""
    from skinviewer.kernel.gpu import GpuServices
    s = small_settings("head", "phong", size=64)
    renderer.render(s)
    counts: list[tuple[int, int]] = []
    real = GpuServices.band_vao

    def spy(self, prog, scene, lod, space, matrix, rows, band, **kw):
        vao, n = real(self, prog, scene, lod, space, matrix, rows, band, **kw)
        counts.append((n, scene.lod_mesh(lod).indices.size))
        return vao, n
    monkeypatch.setattr(GpuServices, "band_vao", spy)
    settle(renderer, with_values(s, {"lights.0.direction": [0.3, 0.2, 1.0]}))
    assert len(counts) >= 4, "the view pass was not drawn band by band through band_vao"
    assert all(n < total for n, total in counts)
    # 8 bands of a 256-row view: the mesh is drawn about once over them
    from skinviewer.kernel.gpu import band_rows
    scene = renderer.scene.gpu
    vp = renderer.view(with_values(s, {"render.width": 256, "render.height": 256})).view_proj
    ys = band_rows(scene, 0, "camera", vp, 256, {})
    kept = [int(((ys[:, 1] >= k * 32 - 2) & (ys[:, 0] <= (k + 1) * 32 + 2)).sum()) for k in range(8)]
    tris = len(scene.lod_mesh(0).indices)
    assert max(kept) < tris and sum(kept) < 1.3 * tris, (kept, tris)


def test_band_shares_follow_the_cost_over_the_rows():
    from skinviewer.kernel.graph import band_shares
    assert np.allclose(band_shares(None, 4), 0.25)
    # all the cost in the middle half of the rows (a face between background rows)
    prof = np.array([0.0, 0.0, 0.5, 1.0, 1.0])
    assert np.allclose(band_shares(prof, 4), [0.0, 0.5, 0.5, 0.0])
    assert np.allclose(band_shares(prof, 8), [0, 0, 0.25, 0.25, 0.25, 0.25, 0, 0])
    assert band_shares(prof, 3).sum() == pytest.approx(1.0)


def test_a_banded_pass_predicts_its_next_band_from_its_cost_over_the_rows(renderer):
    """The bands of a view pass over a head cost more on the face than on the background: the
    graph keeps each banded pass's cost over its rows and predicts the next band by its share
    (so a frame stops before an expensive band instead of overshooting its budget), and sizes the
    bands so the costliest fits half the budget."""
    from skinviewer.kernel.graph import TileProgress
    s = small_settings("head", "phong", size=64)
    renderer.render(s)
    settle(renderer, with_values(s, {"lights.0.direction": [0.3, 0.2, 1.0]}), budget_ms=1e-6)
    g = renderer.graph("phong")
    prof = g._band_profile["phong"]
    assert prof[0] == 0.0 and prof[-1] == pytest.approx(1.0) and np.all(np.diff(prof) >= 0)
    p = next(p for p in g.passes if p.name == "phong")
    r = g._reflect_all(s, renderer.scene.gpu)["phong"]
    # a made-up profile: every cost in the second quarter of the rows
    g._band_profile["phong"] = np.array([0.0, 0.0, 1.0, 1.0, 1.0])
    g._last_ms["phong"], g._last_px["phong"] = 100.0, 64 * 64
    assert g._tile_count(p, r, 100.0) >= 8  # the costly quarter's band at most half the budget
    pr = TileProgress({}, 4)
    assert g._band_next_ms(p, r, pr) == pytest.approx(0.0)  # band 0: background
    pr.done, pr.ms, pr.band_ms = 1, 0.5, [0.5]
    assert g._band_next_ms(p, r, pr) == pytest.approx(100.0)  # band 1 holds the whole cost


@pytest.mark.parametrize("kind", ["directional", "point"])
def test_a_shadow_map_in_bands_is_the_whole_draw(renderer, kind):
    """The shadow maps are split into row bands of the map (issue 27: 20-70 ms at 1024² on llvmpipe, the
    first pass of every light-move frame), each band drawing the triangles that reach its rows in the
    light's clip space: the map is the whole draw's, bit for bit, for a directional and a point light."""
    light = {"kind": kind, "direction": (0.4, 0.3, 1.0), "position": (40.0, 30.0, 120.0)}
    s = small_settings("head", "phong", size=64, **{f"lights.0.{k}": v for k, v in light.items()})
    renderer.render(s)
    g = renderer.graph("phong")
    whole = g.read("shadow_map_0").copy()
    s2 = with_values(s, {"lights.0.intensity": 0.0})  # the map is pruned, then made again in bands
    renderer.render(s2)
    reports = settle(renderer, s)
    runs = [p for rep in reports for p in rep.passes if p.name == "shadow_map_0" and p.status in ("ran", "deferred")]
    assert len(runs) > 2 and any("band" in p.reason for p in runs)
    assert same(g.read("shadow_map_0"), whole)


def test_a_preview_graph_budgets_its_first_frame_by_the_user_graph_s_costs(renderer):
    """A governed preview renders in a graph of its own (Renderer.graph variant): its passes, never
    run there, are budgeted by their cost in the user's graph scaled to their pixels (not as free,
    which ran every pass of a preview's first frame at once: one long frame)."""
    s = small_settings("head", "phong", size=64)
    renderer.render(s)
    base = renderer.graph("phong")
    g = renderer.graph("phong", "preview test-variant")
    p = next(p for p in g.passes if p.name == "phong")
    half = with_values(s, {"render.width": 32, "render.height": 32})
    r = g._reflect_all(half, renderer.scene.gpu)["phong"]
    assert g._expected_ms(p, r) == pytest.approx(base._last_ms["phong"] / 4.0)
    assert g._next_ms(p, r, None, budget_ms=1e9) > 0.0  # the look-ahead sees a cost before its first run
