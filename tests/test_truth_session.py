"""The viewer's progressive ground truth (engine.reference.TruthSession): stages that refine, the
view-independent sources kept across an orbit (identical figures, no rebuild) and a profile change,
rebuilt for a light change, the wide Gaussians' diffusion kept on surface lattices across views
(issue 34), recent truths kept."""
from __future__ import annotations

import numpy as np
import pytest

from skinviewer.engine import reference as R
from skinviewer.ground.settings import Settings, with_values
from skinviewer.scene.scenes import scene_overrides

SIZE = 40


@pytest.fixture(scope="module")
def base():
    return with_values(Settings(), {"scene.name": "backlit-ear", **scene_overrides("backlit-ear"),
                                    "render.width": SIZE, "render.height": SIZE})


@pytest.fixture(scope="module")
def session_and_first(base):
    ses = R.TruthSession()
    parts = list(ses.progressive(base))
    return ses, parts


def test_stages_refine_to_the_whole_view(session_and_first):
    ses, parts = session_and_first
    assert "coarse" in parts[0].stage and not parts[0].final  # a first figure before the sources exist
    assert [p.final for p in parts] == [False] * (len(parts) - 1) + [True]
    # the first two stages are previews: the coarse one, then the first pixels from the sources that
    # reach them (the whole-surface stages compute them again)
    assert "reach them" in parts[1].stage
    fine = [p for p in parts[2:]]
    counts = [int(p.reference.mask.sum()) for p in fine]
    assert counts == sorted(counts) and counts[0] < counts[-1]
    for a, b in zip(fine, fine[1:]):
        assert np.all(b.reference.mask[a.reference.mask])  # a stage keeps the pixels of the last
        # and their values: the diffusion of a pixel is computed once
        m = a.reference.mask
        assert np.array_equal(a.reference.lit[m], b.reference.lit[m])
    assert fine[-1].fraction == 1.0 and ses.builds == 1


def test_final_stage_agrees_with_compute_reference(base, session_and_first):
    """Gathered per pixel (no lattice), the session's truth is compute_reference's integral (only the
    whole-surface clustering differs); with the wide Gaussians on their lattices (the default) it is
    within the interpolation's error, under 1 % per channel."""
    _, parts = session_and_first
    one = R.compute_reference(base, use_cache=False)
    per_pixel = list(R.TruthSession(field_ratio=None).progressive(base))[-1].reference
    m = one.mask
    for final, tol in ((per_pixel, 2e-3), (parts[-1].reference, 1e-2)):
        assert np.array_equal(final.mask, one.mask)
        rel = np.sqrt(((final.lit - one.lit)[m] ** 2).sum(0) / (one.lit[m] ** 2).sum(0))
        assert np.all(rel < tol), rel


def test_an_orbit_reuses_the_diffusion_sources(base, session_and_first):
    ses, _ = session_and_first
    orbit = with_values(base, {"camera.yaw": base.camera.yaw + 25.0})
    parts = list(ses.progressive(orbit))
    assert ses.builds == 1  # no new surface irradiance: only camera rays, specular and the gather
    assert not any("coarse" in p.stage for p in parts)  # straight to the full-resolution sources
    fresh = R.TruthSession()
    again = list(fresh.progressive(orbit))
    assert fresh.builds == 1
    # the same figures (the lattice points evaluated in other batches: the sums' order differs)
    assert np.allclose(parts[-1].reference.lit, again[-1].reference.lit, rtol=1e-6, atol=1e-12)


def test_an_orbit_rebuilds_none_of_the_diffusion_structures(base, session_and_first):
    """The whole-surface structures of the gather (cluster levels, KD-tree, edge frames, source grids)
    are the bulk of an orbit's time when made again for each view (issue 34): an orbit and a profile
    edit re-use them; the figures are those of a session that made them for that view."""
    ses, _ = session_and_first
    built = ses.structures_built(base)
    assert built.get("cluster", 0) >= 1 and built.get("grid", 0) >= 1 and built.get("tree", 0) == 1
    orbit = with_values(base, {"camera.yaw": base.camera.yaw - 35.0, "camera.pitch": base.camera.pitch + 10.0})
    parts = list(ses.progressive(orbit))
    assert ses.structures_built(orbit) == built  # nothing built again
    prof = with_values(orbit, {"deon.gaussians.4.weights": [0.2, 0.3, 0.1]})
    list(ses.progressive(prof))
    assert ses.structures_built(prof) == built
    fresh = R.TruthSession()
    again = list(fresh.progressive(orbit))
    assert fresh.structures_built(orbit) == built  # a fresh session builds the same, once
    assert np.allclose(parts[-1].reference.lit, again[-1].reference.lit, rtol=1e-6, atol=1e-12)


def test_an_orbit_interpolates_the_kept_diffusion_and_matches_a_fresh_truth(base, monkeypatch):
    """Issue 34: the diffused surface radiance does not depend on the camera. Each wide Gaussian's
    exitance is kept on a surface lattice: an orbit evaluates it only where it sees new surface (a
    fraction of what a fresh truth of that view evaluates), coming back to a view evaluates nothing and
    gives its figures again bit for bit, and the orbit's truth matches a truth gathered per pixel for
    that view within the lattice's error (< 1 %; a technique's figure moves by far less than 10 %).
    (Lattices as fine as the pixels here, LATTICE_PAYS 1: at 40x40 the default keeps none.)"""
    monkeypatch.setattr(R, "LATTICE_PAYS", 1.0)
    ses = R.TruthSession()
    a = list(ses.progressive(base))[-1].reference
    n_first = ses.fields_evaluated(base)
    assert n_first > 0
    orbit = with_values(base, {"camera.yaw": base.camera.yaw + 10.0})
    b = list(ses.progressive(orbit))[-1].reference
    n_orbit = ses.fields_evaluated(orbit) - n_first
    fresh = R.TruthSession()
    list(fresh.progressive(orbit))
    assert n_orbit < 0.8 * fresh.fields_evaluated(orbit)  # the surface seen before is not evaluated again
    ses.recent.clear()
    again = list(ses.progressive(base))[-1].reference
    assert ses.fields_evaluated(base) == n_first + n_orbit  # nothing new
    assert np.array_equal(again.lit, a.lit)  # the pixels coincide: identical figures
    per_pixel = list(R.TruthSession(field_ratio=None).progressive(orbit))[-1].reference
    m = per_pixel.mask
    assert np.array_equal(b.mask, m)
    rel = np.sqrt(((b.lit - per_pixel.lit)[m] ** 2).sum(0) / (per_pixel.lit[m] ** 2).sum(0))
    assert np.all(rel < 1e-2), rel
    # a technique's figure (a render 5 % off in a pattern) against either truth: the same to < 10 %
    yy, xx = np.mgrid[0:SIZE, 0:SIZE]
    img = per_pixel.lit * (1.0 + 0.05 * np.sin(xx / 3.0) * np.cos(yy / 4.0))[..., None]
    fig_lattice, _ = R.sampled_rms(img, b, m)
    fig_pixel, _ = R.sampled_rms(img, per_pixel, m)
    assert np.all(np.abs(fig_lattice - fig_pixel) < 0.1 * fig_pixel), (fig_lattice, fig_pixel)


def test_a_profile_change_reuses_a_light_change_rebuilds(base, session_and_first):
    ses, parts = session_and_first
    before = ses.builds
    prof = with_values(base, {"deon.gaussians.5.variance": 4.0})
    p = list(ses.progressive(prof))[-1]
    assert ses.builds == before and not np.array_equal(p.reference.lit, parts[-1].reference.lit)
    light = with_values(base, {"lights.0.intensity": base.lights[0].intensity * 2})
    list(ses.progressive(light))
    assert ses.builds == before + 1


def test_recent_truths_come_back_at_once(base, session_and_first):
    ses, parts = session_and_first
    again = list(ses.progressive(base))
    assert len(again) == 1 and again[0].stage == "recent" and again[0].reference is parts[-1].reference


def test_sampled_rms_uncertainty_is_calibrated_and_shrinks_to_zero():
    """The figure of a partial truth (every 4th / 2nd pixel) brackets the whole image's within its
    standard error as often as a standard error should (synthetic images, smooth truth, noisy render)."""
    rng = np.random.default_rng(7)
    H = W = 96
    yy, xx = np.mgrid[0:H, 0:W]
    inside = []
    for trial in range(40):
        truth = 0.2 + 0.8 * np.exp(-((xx - 48) ** 2 + (yy - 40) ** 2) / (2 * (10 + trial) ** 2))
        truth = np.repeat(truth[..., None], 3, axis=2) * np.array([1.0, 0.7, 0.5])
        img = truth * (1.0 + 0.1 * rng.standard_normal(truth.shape))
        mask = np.ones((H, W), bool)
        full = R.Reference(truth, truth, truth * 0, mask, {"fraction": 1.0})
        rms_full, se_full = R.sampled_rms(img, full, mask)
        assert np.all(se_full == 0)
        for stride in (4, 2):
            m = (yy % stride == 0) & (xx % stride == 0)
            part = R.Reference(np.where(m[..., None], truth, 0.0), truth, truth * 0, m,
                               {"fraction": float(m.mean())})
            rms, se = R.sampled_rms(img, part, mask, seed=trial)
            assert np.all(se > 0) and np.all(np.isfinite(se))
            inside.append(np.abs(rms - rms_full) <= 2 * se)
    assert np.mean(inside) > 0.85


def test_a_kept_source_grid_gives_the_blocks_bit_for_bit():
    """gt.SourceGrid bins the sources once; ``blocks`` with it yields exactly what it yields binning
    them afresh (the same cells, the same source order), and bins afresh for receivers it does not fit."""
    from skinviewer.physics import ground_truth as gt
    rng = np.random.default_rng(3)
    src = rng.uniform(0.0, 40.0, (3000, 3))
    normals = rng.normal(size=(3000, 3))
    for x in (rng.uniform(4.0, 36.0, (500, 3)), np.vstack([rng.uniform(4.0, 36.0, (50, 3)), [[-3.0, 5.0, 5.0]]])):
        for radius in (0.5, 3.0, 9.0):
            grid = gt.SourceGrid(src, max(radius, gt.MIN_CELL))
            assert grid.fits(x) == bool(x.min() >= 0.0)
            fresh = list(gt.blocks(x, src, radius, normals))
            kept = list(gt.blocks(x, src, radius, normals, grid))
            assert len(fresh) == len(kept) > 0
            for a, b in zip(fresh, kept):
                assert all(np.array_equal(u, v) for u, v in zip(a, b))


# -- issue 34: the lattices state their own interpolation error; the session cuts shadow edges; the
# environment's coarse level gives the first figure, an orbit's environment equals a fresh session's ------

def _analytic_cases():
    """(settings, analytic diffuse exitance at surface points (N, 3) mm, scale): the zoomed shadow edge
    (E sum_i w_i Phi((x - x_e) / sigma_i)) and the laser on the slab (Lc sum_i w_i (disc * G_i)(r))."""
    import math

    from scipy.special import ndtr

    from skinviewer.physics import ground_truth as gt
    g = Settings().deon.gaussians
    V = np.array([x.variance for x in g])
    Wt = np.array([x.weights for x in g])
    xe = 21.0 * math.tan(math.radians(30.0))
    edge = with_values(Settings(), {
        "scene.name": "shadow-edge", **scene_overrides("shadow-edge"), "render.width": 24, "render.height": 24,
        "deon.energy_conservation": False, "specular.rho_s": 0.0,
        "lights": [{"kind": "directional", "direction": [-0.5, 0.0, 0.866], "intensity": 0.8, "cast_shadow": True}],
        "camera": {"yaw": 0.0, "pitch": 0.0, "distance": 100.0, "target": [xe, 0.0, 0.0], "fov_y": 3.0}})
    lit = 0.8 * 0.866 / math.hypot(0.5, 0.866)

    def edge_m(p):
        return lit * (Wt[None] * ndtr((p[:, :1] - xe) / np.sqrt(V)[None])[..., None]).sum(1), lit
    slab = with_values(Settings(), {"scene.name": "laser", **scene_overrides("laser"), "render.width": 48,
                                    "render.height": 48, "deon.energy_conservation": False, "specular.rho_s": 0.0,
                                    "lights": [{"kind": "directional", "direction": [0, 0, 1], "intensity": 2.0,
                                                "cast_shadow": True}]})

    def slab_m(p):  # the 24 mm square lit uniformly: E sum_i w_i (square * G_i), its open rim included
        sd = np.sqrt(V)[None, :]

        def box(u):
            return ndtr((12.0 - u) / sd) - ndtr((-12.0 - u) / sd)
        return 2.0 * (Wt[None] * (box(p[:, :1]) * box(p[:, 1:2]))[..., None]).sum(1), 2.0
    laser = with_values(Settings(), {"scene.name": "laser", **scene_overrides("laser"), "render.width": 48,
                                     "render.height": 48, "deon.energy_conservation": False, "specular.rho_s": 0.0})

    def laser_m(p):
        r = np.hypot(p[:, 0], p[:, 1])
        m = 400.0 * sum(Wt[None, i] * gt.gaussian_disc_convolution(r, V[i], 0.02)[:, None] for i in range(len(V)))
        return m, float(m.max())
    return [("edge", edge, edge_m), ("slab", slab, slab_m), ("laser", laser, laser_m)]


@pytest.mark.parametrize("case", [0, 1], ids=["zoomed-edge", "lit-slab"])
def test_the_lattices_state_their_interpolation_error(case):
    """The wide Gaussians' lattices are a surface cache: their interpolation error must lie inside the
    truth's stated per-pixel uncertainty. On two analytic scenes (a cast shadow edge seen from 100 mm
    with a 3 deg field, the 24 mm slab lit uniformly with its open rim), the session's truth with lattices differs from the same
    sources gathered per pixel by no more than its stated uncertainty at >= 99.5 % of the pixels (in RMS
    and at the worst pixel too), and differs from the analytic answer by no more than that plus the
    ruler's own (compute_reference's grid convergence index) at >= 99.5 %; the uncertainty is not
    vacuous: its RMS under 1 % of the lit level on the slab, under 3 % at the edge (the
    whole 5 mm view is a shadow step, where the lattices' error is largest; a loose bound there: the
    error's own RMS is about a fifth of it)."""
    name, s, analytic = _analytic_cases()[case]
    ses = R.TruthSession()
    lat = list(ses.progressive(s))[-1].reference
    assert ses.fields_evaluated(s) > 0  # the lattices were used
    per_pixel = list(R.TruthSession(field_ratio=None).progressive(s))[-1].reference
    ruler = R.compute_reference(s, use_cache=False)
    m = lat.mask & per_pixel.mask & ruler.mask
    assert np.array_equal(lat.mask, per_pixel.mask)
    u = lat.uncertainty[m]
    interp = np.abs(lat.diffuse - per_pixel.diffuse)[m]
    assert interp.max() > 0  # some pixels were interpolated
    assert (interp > u).mean() <= 0.005, (interp > u).mean(0)
    assert np.all(np.sqrt((interp ** 2).mean(0)) <= np.sqrt((u ** 2).mean(0)))
    assert np.all(interp.max(0) <= u.max(0))
    expect, scale = analytic(lat.position[m])
    err = np.abs(lat.diffuse[m] - expect)
    assert (err > u + ruler.uncertainty[m]).mean() <= 0.005, (err > u + ruler.uncertainty[m]).mean(0)
    assert np.sqrt((u ** 2).mean(0)).max() < (0.03 if name == "edge" else 0.01) * scale


def test_a_beam_is_gathered_per_pixel_within_the_rulers_uncertainty():
    """A beam's point sources make the wide Gaussians' fields peak at the sigma scale, where a lattice of
    spacing sigma is off by ~1/8 of the peak: the session keeps no lattice for them, and its truth of the
    laser is the analytic answer within the ruler's uncertainty at >= 99.5 % of the pixels."""
    _, s, analytic = _analytic_cases()[2]
    ses = R.TruthSession()
    ref = list(ses.progressive(s))[-1].reference
    assert ses.fields_evaluated(s) == 0
    ruler = R.compute_reference(s, use_cache=False)
    m = ref.mask & ruler.mask
    expect, _ = analytic(ref.position[m])
    r = np.hypot(ref.position[m][:, 0], ref.position[m][:, 1])
    keep = (r > 0.15) & (r < 8.0)  # as the ruler's own laser test
    err = np.abs(ref.diffuse[m] - expect)[keep]
    assert (err > ruler.uncertainty[m][keep]).mean() <= 0.005


def test_the_session_cuts_the_sources_along_shadow_edges():
    """The session's whole-surface sources are cut along cast shadow edges as compute_reference's (they
    used to carry their corners' mean: 9-20 % of the lit level off at a zoomed edge)."""
    _, s, analytic = _analytic_cases()[0]
    ref = list(R.TruthSession(field_ratio=None).progressive(s))[-1].reference
    expect, lit = analytic(ref.position[ref.mask])
    assert np.abs(ref.diffuse[ref.mask] - expect).max() < 0.01 * lit


def test_the_environment_coarse_first_then_full_and_an_orbit_equals_a_fresh_session(base):
    """With an environment light the first figure uses the coarse estimate of its irradiance (fewer
    rays, at the vertices the coarse sources need), the later stages the full one; the estimate of a
    vertex does not depend on which view asked for it first, so an orbit in a session gives a fresh
    session's truth of that view."""
    s = with_values(base, {"lights": [*[lt.model_dump() for lt in base.lights],
                                      {"kind": "environment", "intensity": 0.5, "cast_shadow": False}]})
    ses = R.TruthSession()
    gen = ses.progressive(s)
    first = next(gen)
    surf = ses.surface(s)
    assert "coarse" in first.stage
    assert surf.env_done["coarse"].sum() > 0 and surf.env_done["full"].sum() == 0  # no full estimate yet
    rest = list(gen)
    assert rest[-1].final and surf.env_done["full"].sum() > 0
    orbit = with_values(s, {"camera.yaw": s.camera.yaw + 25.0})
    a = list(ses.progressive(orbit))[-1].reference
    b = list(R.TruthSession().progressive(orbit))[-1].reference
    assert np.allclose(a.lit, b.lit, rtol=1e-6, atol=1e-12)


# the environment at the pixels' own points, and the uncertainty stated for it (issue 34) ------------------

def _head_with_environment(size: int):
    """The default head (detail 0) with the default studio environment and key light."""
    return with_values(Settings(), {"scene.name": "head", "scene.head_detail": 0, "render.width": size,
                                    "render.height": size})


class _LocalOnly:
    """A diffusion whose only Gaussian is the delta (weight 1): env_point_uncertainty's E A itself."""
    v = np.array([0.0])
    w = np.ones((1, 3))

    @staticmethod
    def method(v):
        return ("delta", None)


def test_the_pixels_environment_is_estimated_at_their_points_within_its_stated_uncertainty():
    """The truth's E A at a pixel takes the environment estimated at the pixel's own point (it used to be
    interpolated between three estimates inside each ~2.8 mm triangle). Against independent estimates
    with 4x the rays, the difference is inside the two estimates' stated uncertainties at >= 99 % of
    the pixels of the default head with its studio environment; the interpolated value is not (its
    error is the triangles', which no stated uncertainty covered)."""
    s = _head_with_environment(32)
    surf = R.Surface(*R.load_scene(s), s)
    mask, tri, bary, _ = R.camera_hits(surf, s)
    a = surf.attributes(tri, bary)
    mix, energy = s.deon.mix, s.deon.energy_conservation
    sel = np.ones(len(tri), bool)
    no_env = surf.irradiance(a, mix, energy, env_level="none")
    ea, se = surf.irradiance_at_points(a, mix, energy, seed=1)
    e_j, s_j = surf.env_direct(a, energy, rays=4 * R.ENV_DIFFUSE_RAYS, seed=2)
    cm = R._safe_pow(a["C"], mix)
    ea_j, se_j = no_env + e_j * cm, s_j * cm
    u = R.env_point_uncertainty(_LocalOnly(), se, ea - no_env, sel)
    u_j = R.env_point_uncertainty(_LocalOnly(), se_j, ea_j - no_env, sel)
    assert np.all(u > 0)
    d = np.abs(ea - ea_j)
    assert (d <= u + u_j).mean() >= 0.99, (d <= u + u_j).mean(0)
    assert np.sqrt((u ** 2).mean()) < 0.05 * np.sqrt((ea ** 2).mean())  # not vacuous
    # the interpolation between the three estimates inside each triangle, as the truth did
    ids = np.unique(3 * tri[:, None] + np.arange(3)[None])
    surf._env_estimate(ids, energy, "full")
    ids3, w = surf._env_support("full", tri, bary)
    interp = no_env + np.einsum("nk,nkc->nc", w, surf.env_val["full"][ids3]) * cm
    d_old = np.abs(interp - ea_j)
    assert (d_old <= u + u_j).mean() < 0.99


def test_the_sessions_uncertainty_covers_the_pixels_environment():
    """On a scene with an environment, the session's truth differs from the same truth with the pixels'
    environment estimated independently with 4x the rays by no more than the stated uncertainty (the
    two truths' together) at >= 99 % of the pixels, and the window's words say what it covers (where the
    viewer's packages are installed: the GPU check carries none)."""
    s = with_values(Settings(), {"scene.name": "shadow-edge", **scene_overrides("shadow-edge"), "render.width": 24,
                                 "render.height": 24})
    s = with_values(s, {"lights": [*[lt.model_dump() for lt in s.lights], {"kind": "environment", "intensity": 0.6}]})
    ses = R.TruthSession()
    ref = list(ses.progressive(s))[-1].reference
    assert "environment" in ref.meta["uncertainty"]
    try:
        from skinviewer.ui.accuracy_window import uncertainty_words
    except ModuleNotFoundError as exc:  # the viewer's imgui is an optional extra
        assert exc.name == "imgui_bundle", exc
    else:
        assert "environment" in uncertainty_words(ref.meta)
    real = R.Surface.env_direct
    try:
        R.Surface.env_direct = lambda self, a, energy, rays=R.ENV_DIFFUSE_RAYS, seed=0: real(
            self, a, energy, 4 * rays, seed + 99991)
        ses.recent.clear()
        judge = list(ses.progressive(s))[-1].reference
    finally:
        R.Surface.env_direct = real
    m = ref.mask
    d = np.abs(ref.lit - judge.lit)[m]
    u = (ref.uncertainty + judge.uncertainty)[m]
    assert d.max() > 0  # the estimates differ
    assert (d <= u).mean() >= 0.99, (d <= u).mean(0)


def test_the_environment_interpolated_at_the_source_elements_is_in_the_stated_uncertainty():
    """The source elements read the environment linearly between three estimates inside each mesh
    triangle; at a fold that is off by much of the value. On the default head's ear (detail 0, where
    that error is largest), the diffusion from those elements differs from the same diffusion with the
    environment estimated at every element corner itself (2x the rays, other seeds) by more than the
    estimates' noise, and by no more than the stated uncertainty (as the session computes it: each
    triangle's corner checks through the same Gaussians but the delta, env_interpolation_exitance) at
    >= 90 % of the pixels per channel and in RMS (measured: 100 / 100 / 100 %, the ± 20 / 12 / 11 x the
    error in the median; the nearest checks' mean the session used before session 11: 100 / 100 / 98 %,
    11 / 6.5 / 6.8 x); the uncertainty is not vacuous (RMS under 30 % of M; measured 17 / 23 / 24 %, the
    nearest checks' 9 %: the corners bound a triangle's mean error 1.6-4.9 x over)."""
    s = _head_with_environment(16)
    surf = R.Surface(*R.load_scene(s), s)
    mix, energy = s.deon.mix, s.deon.energy_conservation
    P = surf.P * surf.mm
    tc = P[surf.F].mean(1)
    p0 = P[np.argmax(P[:, 0])]  # the ear's rim
    rng = np.random.default_rng(1)
    tri = rng.choice(np.nonzero(np.linalg.norm(tc - p0, axis=1) < 5.0)[0], 48)
    bary = rng.dirichlet(np.ones(3), 48)
    a = surf.attributes(tri, bary)
    x = a["P"] * surf.mm
    variances, weights = R.profile_of(s)
    h = 2.0
    ea, _ = surf.irradiance_at_points(a, mix, energy, seed=3)
    interp = R.build_diffusion(surf, x, h, variances, weights, mix, energy)
    el_i, h_i = R.env_interpolation_sources(surf, mix, energy, h)  # the triangles whose estimates it made
    u = R.env_interpolation_exitance(R.gt.Diffusion(el_i, variances, weights, h_i), x, None)
    real = R.Surface.env_irradiance
    try:
        R.Surface.env_irradiance = lambda self, t, b, energy, level="full": self.env_direct(
            self.attributes(t, b), energy, rays=2 * R.ENV_DIFFUSE_RAYS, seed=len(t) + 7)[0]
        judge = R.build_diffusion(surf, x, h, variances, weights, mix, energy)
    finally:
        R.Surface.env_irradiance = real
    M, M_judge = interp.exitance(x, ea), judge.exitance(x, ea)
    d = np.abs(M - M_judge)
    print("coverage", (d <= u).mean(0), "median u / error", np.median(u / np.maximum(d, 1e-300), axis=0),
          "RMS error / M", np.sqrt((d ** 2).mean(0) / (M ** 2).mean(0)), "RMS u / M", np.sqrt((u ** 2).mean(0) / (M ** 2).mean(0)))
    assert np.all(np.sqrt((d ** 2).mean(0) / (M ** 2).mean(0)) > 0.005)  # an error worth stating
    assert np.all((d <= u).mean(0) >= 0.9), (d <= u).mean(0)
    assert np.all(np.sqrt((d ** 2).mean(0)) <= np.sqrt((u ** 2).mean(0)))
    assert np.all(np.sqrt((u ** 2).mean(0) / (M ** 2).mean(0)) < 0.3)


def test_lattice_refine_takes_the_largest_parts_until_the_target_or_the_cap():
    """lattice_refine picks the pixels with the largest share of the lattices' stated uncertainty in the
    view's relative RMS, fewest first, until what is left is <= LATTICE_TARGET in every channel, and
    never more than LATTICE_REFINE_MAX of the pixels; nothing when the target is met already."""
    n = 1000
    u = np.full((n, 3), 1e-4)
    u[:30] = 0.2  # 3 % of the pixels hold nearly all of it
    ref = np.ones(3)
    redo = R.TruthSession.lattice_refine(u, ref)
    assert redo[:30].all() and redo.sum() == 30
    left = u.copy()
    left[redo] = 0.0
    assert np.all(np.sqrt((left ** 2).mean(0)) <= R.LATTICE_TARGET * ref)
    assert not R.TruthSession.lattice_refine(np.full((n, 3), 1e-4), ref).any()
    assert R.TruthSession.lattice_refine(np.full((n, 3), 1.0), ref).sum() == int(R.LATTICE_REFINE_MAX * n)


def test_the_back_lit_flaps_lattice_uncertainty_is_refined_below_the_target_and_still_covers():
    """On the back-lit flap at 128x128 the lattices' stated +- was 4-6 % of the lit level (RMS), as large as
    a technique's figure, while their real error is ~0.6 %: the session now gathers the wide Gaussians
    exactly at the pixels with the largest part, so the final +- is within LATTICE_TARGET (+ truncation)
    of the view's RMS, and it still covers the difference to the same truth gathered per pixel at
    >= 99 % of the pixels."""
    s = with_values(Settings(), {"scene.name": "backlit-ear", **scene_overrides("backlit-ear"), "render.width": 128,
                                 "render.height": 128})
    ses = R.TruthSession()
    ref = list(ses.progressive(s))[-1].reference
    assert ses.fields_evaluated(s) > 0 and ses.refined > 0
    per_pixel = list(R.TruthSession(field_ratio=None).progressive(s))[-1].reference
    m = ref.mask & per_pixel.mask
    u, lit = ref.uncertainty[m], ref.lit[m]
    err = np.abs(ref.diffuse - per_pixel.diffuse)[m]
    assert np.all(np.sqrt((u ** 2).mean(0) / (lit ** 2).mean(0)) <= R.LATTICE_TARGET + 2 * R.TRUNCATE_LOSS)
    assert np.all((err <= u).mean(0) >= 0.99), (err <= u).mean(0)
