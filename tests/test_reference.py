"""The ground truth (skinviewer.physics.ground_truth, skinviewer.engine.reference) against analytic
convolutions, itself at two source resolutions, energy balance and rotation invariance. Small
sizes: the whole file runs in well under 30 s."""
from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.special import ndtr

from skinviewer.engine.reference import Surface, build_diffusion, compute_reference
from skinviewer.ground.settings import Settings, with_values
from skinviewer.physics import ground_truth as gt
from skinviewer.physics.metrics import rel_rms
from skinviewer.scene.mesh import MeshData, vertex_normals
from skinviewer.scene.scenes import grid, scene_overrides

SKIN = Settings().deon.gaussians
V = np.array([g.variance for g in SKIN])
W = np.array([g.weights for g in SKIN])


def _settings(scene: str, size: int = 64, **assign) -> Settings:
    return with_values(Settings(), {"scene.name": scene, **scene_overrides(scene), "render.width": size,
                                    "render.height": size, **assign})


def test_gaussian_triangle_mass_is_exact():
    """Owen's-T integral of the unit 2D normal over triangles = a fine quadrature of the same."""
    rng = np.random.default_rng(3)
    b, t = gt.subdivision_pattern(300)
    for _ in range(4):
        q = rng.normal(size=(3, 2)) * 1.2
        pts = b @ q
        sub = pts[t]
        c = sub.mean(1)
        e1, e2 = sub[:, 1] - sub[:, 0], sub[:, 2] - sub[:, 0]
        area = 0.5 * np.abs(e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0])
        ref = (area * np.exp(-(c * c).sum(1) / 2) / (2 * np.pi)).sum()
        got = gt.gaussian_triangle_mass(q[0], q[1], q[2])
        assert abs(got - ref) < 1e-5
        # orientation does not matter
        assert abs(gt.gaussian_triangle_mass(q[0], q[2], q[1]) - got) < 1e-12


def test_diffusion_exact_element_integral_is_the_tested_mass():
    """Production's per-element integral (Diffusion._exact, which calls gaussian_triangle_mass) on tilted
    3-D triangles and points off their plane = a fine midpoint quadrature of G(v, |x - y|) over the
    triangle (eq. 20: 1/(2 pi v) exp(-|x - y|^2 / 2v) in 2-D times the plane-distance factor)."""
    rng = np.random.default_rng(5)
    b, t = gt.subdivision_pattern(200)
    corners = rng.normal(size=(3, 3, 3)) * 1.5
    el = gt.Elements(corners, np.zeros((3, 3)))
    d = gt.Diffusion(el, V, W, 0.5)
    x = rng.normal(size=(3, 3)) * 0.8
    j = np.arange(3)
    for v in (0.0484, 0.567, 1.99):
        got = d._exact(x, j, v)
        for k in range(3):
            sub = (b @ corners[k])[t]
            c = sub.mean(1)
            area = 0.5 * np.linalg.norm(np.cross(sub[:, 1] - sub[:, 0], sub[:, 2] - sub[:, 0]), axis=1)
            r2 = ((c - x[k]) ** 2).sum(1)
            ref = (area * np.exp(-r2 / (2 * v)) / (2 * np.pi * v)).sum()
            # quadrature residual measured <= 1.3e-5 relative, 2e-7 absolute (narrowest v)
            assert abs(got[k] - ref) < 5e-5 * ref + 1e-6, (v, k, got[k], ref)


def test_edge_on_a_plane_matches_erf():
    """A sharp irradiance step on a plane along element edges: every Gaussian keeps its exact
    weight (Owen's T for the narrow ones, moment-matched clusters for the wide ones), so
    M(x) = sum_i w_i Phi(x / sigma_i) everywhere, right at the step too."""
    pos, _, _, idx = grid(40, 40, 40.0, 40.0)
    h = 0.5
    vpar, vb, el_idx = gt.subdivide(pos[idx], h)
    vp = np.einsum("vk,vkd->vd", vb, pos[idx][vpar])
    el = gt.Elements(vp[el_idx], np.zeros((len(el_idx), 3)))
    el.ea[:] = el.centroid[:, :1] > 0
    x = np.stack([np.linspace(-6, 6, 97), np.linspace(-3, 3, 97), np.zeros(97)], 1)
    ea_x = np.repeat((x[:, :1] > 0).astype(float), 3, 1)
    d = gt.Diffusion(el, V, W, h)
    assert any("Owen" in p for p in d.plan()) and any("clusters" in p for p in d.plan())
    M = d.exitance(x, ea_x)
    ref = (W[None] * ndtr(x[:, :1, None] / np.sqrt(V)[None, :, None])).sum(1)
    assert np.abs(M - ref).max() < 1e-3


XE = 21.0 * math.tan(math.radians(30.0))  # shadow-edge lit at 30 deg: the blade's top edge (x 0, z 21) casts x = XE


def _zoomed_edge(size: int = 24, **assign) -> Settings:
    """shadow-edge lit from -0.5, 0, 0.866, a camera 100 mm above the cast edge with a 3 deg field
    (5.2 mm across); no specular, rho_dt off."""
    return _settings("shadow-edge", size, **{
        "deon.energy_conservation": False, "specular.rho_s": 0.0,
        "lights": [{"kind": "directional", "direction": [-0.5, 0.0, 0.866], "intensity": 0.8, "cast_shadow": True}],
        "camera": {"yaw": 0.0, "pitch": 0.0, "distance": 100.0, "target": [XE, 0.0, 0.0], "fov_y": 3.0}, **assign})


def _edge_analytic(p: np.ndarray) -> tuple[np.ndarray, float]:
    """M across a straight shadow edge: E sum_i w_i Phi((x - XE) / sigma_i), and E."""
    lit = 0.8 * 0.866 / math.hypot(0.5, 0.866)
    return lit * (W[None] * ndtr((p[:, :1] - XE) / np.sqrt(V)[None])[..., None]).sum(1), lit


def test_zoomed_shadow_edge_is_converged():
    """Elements the cast edge crosses are cut along it (shadow-ray bisection) and each side integrated
    exactly: within 1 % of the lit level at every pixel of a 5 mm window across the edge, at the
    default 0.5 mm elements (corner means smeared it to 9 / 17 / 20 %)."""
    ref = compute_reference(_zoomed_edge(), use_cache=False)
    p = ref.position[ref.mask]
    expect, lit = _edge_analytic(p)
    assert ref.mask.all() and (p[:, 0] < XE - 2).any() and (p[:, 0] > XE + 2).any()
    err = np.abs(ref.diffuse[ref.mask] - expect) / lit
    assert err.max() < 0.01, err.max(0)
    _uncertainty_bounds_the_error(ref, expect, ref.mask, lit)


def _uncertainty_bounds_the_error(ref, expect: np.ndarray, sel: np.ndarray, scale: float) -> None:
    """The truth's stated per-pixel uncertainty is at least its true error (against an analytic
    answer) at >= 99.5 % of the pixels, in RMS and at the worst pixel; and it is not vacuous: its
    RMS stays under 1 % of ``scale`` (the lit level)."""
    u = ref.uncertainty[sel]
    err = np.abs(ref.diffuse[sel] - expect)
    assert u.shape == err.shape and np.all(u > 0)
    assert (err > u).mean() <= 0.005, (err > u).mean(0)
    assert np.all(np.sqrt((err ** 2).mean(0)) <= np.sqrt((u ** 2).mean(0)))
    assert np.all(err.max(0) <= u.max(0))
    assert np.sqrt((u ** 2).mean(0)).max() < 0.01 * scale


def test_lit_plane_matches_analytic_convolution():
    """The 24 mm slab under a uniform light: M = E sum_i w_i (square * G_i), edges included."""
    s = _settings("laser", 48, **{"lights": [{"kind": "directional", "direction": [0, 0, 1], "intensity": 2.0,
                                               "cast_shadow": True}],
                                  "deon.energy_conservation": False, "specular.rho_s": 0.0})
    ref = compute_reference(s, use_cache=False)
    m = ref.mask
    p = ref.position[m]
    a = 12.0

    def box(u, sd):
        return ndtr((a - u) / sd) - ndtr((-a - u) / sd)

    sd = np.sqrt(V)[None, :]
    expect = 2.0 * (W[None] * (box(p[:, :1], sd) * box(p[:, 1:2], sd))[..., None]).sum(1)
    got = ref.diffuse[m]
    assert m.sum() > 500
    assert rel_rms(got, expect).max() < 0.005
    assert np.abs(got - expect).max() < 0.005 * expect.max()
    assert np.abs(ref.specular).max() == 0
    _uncertainty_bounds_the_error(ref, expect, m, 2.0)


def test_laser_matches_disc_convolution():
    """GPU Gems 3 §14.4.1: a 0.02 mm beam on the slab; M(r) = Lc sum_i w_i (disc * G_i)(r)."""
    s = _settings("laser", 64, **{"deon.energy_conservation": False, "specular.rho_s": 0.0})
    ref = compute_reference(s, use_cache=False)
    p = ref.position[ref.mask]
    r = np.hypot(p[:, 0], p[:, 1])
    keep = (r > 0.15) & (r < 8.0)
    expect = 400.0 * sum(W[None, i] * gt.gaussian_disc_convolution(r[keep], V[i], 0.02)[:, None]
                         for i in range(len(V)))
    got = ref.diffuse[ref.mask][keep]
    assert keep.sum() > 300
    assert rel_rms(got, expect).max() < 0.005
    assert ref.meta["beam_rays"] > 0
    sel = ref.mask.copy()
    sel[ref.mask] = keep
    _uncertainty_bounds_the_error(ref, expect, sel, float(expect.max()))


def test_two_source_resolutions_agree():
    """The thin flap lit from behind (transmission through 1.5-6 mm): 0.5 mm and 0.35 mm elements."""
    s = _settings("backlit-ear", 48)
    a = compute_reference(s, h_mm=0.5, use_cache=False)
    b = compute_reference(s, h_mm=0.35, use_cache=False)
    m = a.mask & b.mask
    assert a.diffuse[m].mean() > 0.01  # transmitted light is there
    assert rel_rms(a.lit, b.lit, m).max() < 0.005


def _sphere(rot: np.ndarray | None = None) -> MeshData:
    import trimesh
    sp = trimesh.creation.icosphere(subdivisions=3, radius=15.0)
    p = np.asarray(sp.vertices, np.float64)
    uv = np.stack([0.5 + np.arctan2(p[:, 2], p[:, 0]) / (2 * np.pi), 0.5 + np.arcsin(p[:, 1] / 15.0) / np.pi], 1)
    if rot is not None:
        p = p @ rot.T
    idx = np.asarray(sp.faces)
    return MeshData(p, vertex_normals(p, idx), uv, idx, albedo=np.full((2, 2, 3), 0.8, np.float32))


def _sphere_exitance(rot, light_dir, every: int = 1):
    s = with_values(Settings(), {"lights": [{"kind": "directional", "direction": list(light_dir), "intensity": 1.0}]})
    surf = Surface(_sphere(rot), 1.0, s)
    d = build_diffusion(surf, surf.P, 1.5, V, W, s.deon.mix, True)
    return d, d.exitance(d.el.centroid[::every])


def test_power_in_equals_power_out_and_rotation_invariance():
    rng = np.random.default_rng(7)
    L = np.array([0.3, 0.5, 1.0])
    d0, M0 = _sphere_exitance(None, L)
    power_in = (d0.el.ea * d0.el.area[:, None]).sum(0)
    power_out = (M0 * d0.el.area[:, None]).sum(0)
    # on a sphere the chord-distance Gaussian integrates to 1 - exp(-2 R^2 / v): out = sum_i w_i in
    np.testing.assert_allclose(power_out, W.sum(0) * power_in, rtol=0.005)
    q, _ = np.linalg.qr(rng.normal(size=(3, 3)))
    q *= np.sign(np.linalg.det(q))
    d1, M1 = _sphere_exitance(q, q @ L, every=7)  # the clusters' voxel grid does not rotate with it
    # the same elements (a grazing self-shadow edge's pieces: its crossing is found by shadow rays to
    # 2^-11 of an element, which rounding moves by up to ~1e-3 mm under a rotation)
    np.testing.assert_array_equal(d1.el.split, d0.el.split)
    whole = ~d0.el.split
    np.testing.assert_allclose(d1.el.centroid[whole], d0.el.centroid[whole] @ q.T, atol=1e-5)
    np.testing.assert_allclose(d1.el.centroid, d0.el.centroid @ q.T, atol=2e-3)
    assert rel_rms(M1[:, None, :], M0[::7, None, :]).max() < 0.005


def test_estimate_refuses_huge_requests():
    from skinviewer.engine.reference import ReferenceTooSlow
    s = _settings("laser", 64)
    with pytest.raises(ReferenceTooSlow, match="would take about"):
        compute_reference(s, use_cache=False, max_seconds=1e-6)


def test_cache_roundtrip(tmp_path, monkeypatch):
    monkeypatch.setenv("SKINVIEWER_CACHE", str(tmp_path))
    s = _settings("laser", 32)
    a = compute_reference(s)
    b = compute_reference(s)
    assert not a.meta["cached"] and b.meta["cached"]
    np.testing.assert_allclose(a.lit, b.lit, rtol=1e-6, atol=1e-30)
    c = compute_reference(with_values(s, {"lights.0.intensity": 100.0}))
    assert not c.meta["cached"]
    assert math.isclose(float(c.lit.sum()) / float(a.lit.sum()), 100.0 / 400.0, rel_tol=1e-4)


def test_a_dipole_truth_follows_the_dipole():
    """--profile dipole: the laser's exitance follows the normalised Jensen 2001 dipole R(r) / R_d
    (32 fixed-variance Gaussians fitted to r R(r), each integrated exactly)."""
    from skinviewer.engine.reference import model_profile
    from skinviewer.physics import profiles as P
    v, w, err = model_profile("dipole", "Skin1")
    assert err.max() < 1e-3
    s = _settings("laser", 64, **{"deon.energy_conservation": False, "specular.rho_s": 0.0})
    ref = compute_reference(s, use_cache=False, profile=(v, w))
    p = ref.position[ref.mask]
    r = np.hypot(p[:, 0], p[:, 1])
    keep = (r > 0.3) & (r < 5.0)
    m = P.material("Skin1")
    dip = P.Dipole(m.sigma_s_prime, m.sigma_a, m.eta)
    expect = 400.0 * np.pi * 0.02 ** 2 * dip(r[keep]) / dip.total_reflectance()[None]
    assert rel_rms(ref.diffuse[ref.mask][keep], expect).max() < 0.01


def test_truth_sees_the_view_the_renderer_draws(renderer):
    """The truth's camera is the renderer's (same framing of a bust on its head): its pixel mask
    matches the technique's coverage on the default head."""
    from skinviewer.engine.bench import linear_image
    from skinviewer.engine.reference import Surface, camera_hits, load_scene
    s = with_values(Settings(), {"technique": "phong", "render.width": 64, "render.height": 64,
                                 "shadow.map_size": 256})
    mesh, mm = load_scene(s)
    mask = camera_hits(Surface(mesh, mm, s), s)[0]
    renderer.render(s)
    _, cov = linear_image(renderer, s)
    iou = (mask & cov).sum() / max((mask | cov).sum(), 1)
    assert iou > 0.95, iou


def test_reference_cli_writes_the_uncertainty_beside_the_image(tmp_path, monkeypatch, capsys):
    """`skinviewer reference --npy X.npy --exr X.exr`: X.uncertainty.npy beside the image, an EXR layer
    uncertainty.R/G/B, and its median / p99 printed."""
    import OpenEXR

    from skinviewer.cli import main
    monkeypatch.setenv("SKINVIEWER_CACHE", str(tmp_path / "cache"))
    rc = main(["reference", "--scene", "laser", "--size", "24x24", "--out", str(tmp_path / "r.png"),
               "--npy", str(tmp_path / "r.npy"), "--exr", str(tmp_path / "r.exr")])
    assert rc == 0
    img, u = np.load(tmp_path / "r.npy"), np.load(tmp_path / "r.uncertainty.npy")
    assert u.shape == img.shape and np.all(u >= 0) and u.max() > 0
    with OpenEXR.File(str(tmp_path / "r.exr"), separate_channels=True) as f:
        ch = f.channels()
        assert {"uncertainty.R", "uncertainty.G", "uncertainty.B"} <= set(ch)
        np.testing.assert_allclose(np.asarray(ch["uncertainty.G"].pixels), u[..., 1], rtol=1e-6)
    assert "uncertainty of the image" in capsys.readouterr().out


def test_the_shipped_preview_errors_carry_the_rulers_uncertainty():
    """benchmarks/bench_governor_errors.py writes, beside each preview rung's error (key "errors"), the
    ground truth's uncertainty of that figure (key "uncertainty", metrics.figure_uncertainty's RMS
    bound, mean over channels) for every rung, so the status line can read "6.1 % ± 0.4"."""
    import json

    from skinviewer.engine.calibration import ERRORS_TABLE
    data = json.loads(ERRORS_TABLE.read_text(encoding="utf-8"))
    errors, unc = data["errors"], data["uncertainty"]
    assert errors and set(unc) == set(errors)
    assert all(np.isfinite(v) and 0.0 < v < 0.1 for v in unc.values()), unc
    from skinviewer.engine.reference import VERSION
    assert data["truth_version"] == VERSION  # measured with today's ruler, not an older truth's ±
    # the quarter view's cost in accuracy is measured, not inside the ruler's doubt (with truth version 10
    # d'Eon's final rungs, 4.7 %, are within its ± 4.85 %: the status line shows "4.7 % ± 4.9")
    quarter = [k for k in errors if json.loads(k)[2] == 0.25]
    assert quarter and all(errors[k] > 2.0 * unc[k] for k in quarter), {k: (errors[k], unc[k]) for k in quarter}


def test_refining_the_truth_at_chosen_pixels_tightens_its_uncertainty_there_and_still_bounds_the_error():
    """reference.refine_at (issue 30 item 4): the lit slab's rim pixels (where the truth's stated
    uncertainty is largest), recomputed with finer elements: the other pixels are untouched, the stated
    uncertainty still covers the true error (the analytic open square) at every refined pixel and is
    smaller there than before, the error is no larger (to the truncation level both share); a truth of another view is refused."""
    from skinviewer.engine.reference import refine_at
    s = _settings("laser", 32, **{"lights": [{"kind": "directional", "direction": [0, 0, 1], "intensity": 2.0,
                                               "cast_shadow": True}],
                                  "deon.energy_conservation": False, "specular.rho_s": 0.0})
    ref = compute_reference(s, use_cache=False)
    m = ref.mask
    u = ref.uncertainty[..., 1]
    sel = m & (u >= np.quantile(u[m], 0.9))
    out = refine_at(s, ref, sel)
    assert out.meta["refined"]["pixels"] == int(sel.sum())
    np.testing.assert_array_equal(out.lit[~sel], ref.lit[~sel])
    np.testing.assert_array_equal(out.uncertainty[~sel], ref.uncertainty[~sel])
    p = ref.position[sel]
    sd = np.sqrt(V)[None, :]

    def box(x, a=12.0):
        return ndtr((a - x) / sd) - ndtr((-a - x) / sd)
    expect = 2.0 * (W[None] * (box(p[:, :1]) * box(p[:, 1:2]))[..., None]).sum(1)
    err_before, err_after = np.abs(ref.diffuse[sel] - expect), np.abs(out.diffuse[sel] - expect)
    assert np.all(err_after <= out.uncertainty[sel])
    u_after, u_before = (np.sqrt((r.uncertainty[sel] ** 2).mean(0)) for r in (out, ref))
    assert np.all(u_after < 0.8 * u_before) and u_after.max() < 0.5 * u_before.max()  # the rest: truncation
    slack = 5e-5 * expect.max()  # TRUNCATE_LOSS: the level both share
    assert np.all(np.sqrt((err_after ** 2).mean(0)) <= np.sqrt((err_before ** 2).mean(0)) + slack)
    with pytest.raises(ValueError, match="view"):
        refine_at(with_values(s, {"camera.yaw": 30.0}), ref, sel)


def test_refining_under_an_environment_reads_it_at_the_pixel_and_stays_within_its_uncertainty():
    """refine_at with an environment light (the Gaussians narrower than 0.25 mm read its irradiance
    estimated at the pixel's own point, the wider ones the interpolated estimates with more rays): the
    slab under the studio environment alone, whose upper hemisphere nothing blocks, so the irradiance is
    the same everywhere and M = E sum_i w_i (square * G_i); at the refined rim pixels the refined truth
    matches that within its stated uncertainty, which is small (< 1 % of E)."""
    from skinviewer.engine.reference import refine_at
    s = _settings("laser", 24, **{"lights": [{"kind": "environment", "environment": "studio", "intensity": 1.0,
                                               "cast_shadow": False}],
                                  "deon.energy_conservation": False, "specular.rho_s": 0.0})
    ref = compute_reference(s, use_cache=False)
    m = ref.mask
    p = ref.position[m]
    sd = np.sqrt(V)[None, :]

    def box(x, a=12.0):
        return ndtr((a - x) / sd) - ndtr((-a - x) / sd)
    shape = (W[None] * (box(p[:, :1]) * box(p[:, 1:2]))[..., None]).sum(1)
    centre = np.argmin(np.hypot(p[:, 0], p[:, 1]))
    E = ref.diffuse[m][centre] / shape[centre]
    r = np.hypot(p[:, 0], p[:, 1])
    sel = m.copy()
    sel[m] = np.abs(np.abs(p[:, :2]).max(1) - 12.0) < 1.0  # within 1 mm of the square's rim
    assert sel.sum() >= 8
    out = refine_at(s, ref, sel)
    expect = (E[None] * shape)[sel[m]]
    err = np.abs(out.diffuse[sel] - expect)
    assert np.all(err <= out.uncertainty[sel] + 1e-3 * E)  # E itself from the centre pixel: to 0.1 %
    assert np.all(out.uncertainty[sel] < 0.01 * E)
    assert r.max() > 12.0


def _blade_under_an_environment():
    """The shadow-edge scene's plane and blade, coarsely tessellated (3.75 mm triangles, the head's scale:
    few environment estimates), under the studio environment alone: the blade hides part of the sky
    from the plane, so the environment's irradiance is a Monte Carlo estimate with a real error."""
    from skinviewer.scene.scenes import _box, _merge
    plane = grid(16, 16, 60.0, 60.0, uv_rect=(0.02, 0.02, 0.78, 0.98))
    blade = _box((-17.5, 0.0, 20.0), (35.0, 80.0, 2.0), uv_rect=(0.82, 0.02, 0.98, 0.40))
    pos, nrm, uv, idx = _merge([plane, blade])
    mesh = MeshData(pos, nrm, uv, idx, name="blade-env", albedo=np.ones((4, 4, 3), np.float32))
    s = _settings("shadow-edge", 32, **{"lights": [{"kind": "environment", "environment": "studio",
                                                     "intensity": 1.0}]})
    return s, (mesh, 1.0)


def test_the_uncertainty_states_the_environments_monte_carlo_error(monkeypatch):
    """compute_reference's uncertainty with an environment light covers the Monte Carlo error of its
    irradiance estimates (issue 30): against the same truth with 8x the rays (its own error ~1/3 of
    the default's), the default truth's error is within its stated uncertainty at >= 98 % of the
    pixels and in RMS; without the environment term (env_mc_uncertainty) the same uncertainty misses
    it at > 5 % of the pixels, so the term is what covers it."""
    import skinviewer.engine.reference as R
    s, scene = _blade_under_an_environment()
    # the interpolation's term (its check holds Monte Carlo error too) is left out: this asks what the
    # Monte Carlo term alone covers (the next test: the interpolation's)
    monkeypatch.setattr(R, "env_interpolation_uncertainty", lambda surf, pts, *_a, **_k: np.zeros((len(pts["P"]), 3)))
    a = compute_reference(s, h_mm=1.0, scene=scene)
    assert "Monte Carlo" in a.meta["uncertainty"] and a.meta["seconds"]["uncertainty_env"] >= 0
    monkeypatch.setattr(R, "env_mc_uncertainty", lambda surf, pts, *_a, **_k: np.zeros((len(pts["P"]), 3)))
    without = compute_reference(s, h_mm=1.0, scene=scene)
    monkeypatch.setattr(R, "ENV_DIFFUSE_RAYS", 8 * R.ENV_DIFFUSE_RAYS)
    converged = compute_reference(s, h_mm=1.0, scene=scene)
    m = a.mask & (a.lit.sum(-1) > 0)
    assert m.sum() > 300
    np.testing.assert_array_equal(a.lit, without.lit)  # seeded: the same estimates, only the uncertainty differs
    err = np.abs(a.lit - converged.lit)[m]
    u, u0 = a.uncertainty[m], without.uncertainty[m]
    assert np.all((err > u).mean(0) <= 0.02), (err > u).mean(0)
    assert np.all(np.sqrt((err ** 2).mean(0)) <= np.sqrt((u ** 2).mean(0)))
    assert np.all((err > u0).mean(0) > 0.05), (err > u0).mean(0)
    # not vacuous: the stated RMS within 10x the true RMS error (measured: 5-7x, misses 0.8-1.4 %; without the
    # term 24 %) and under 10 % of the image's RMS (measured 6-8 %: 3.75 mm triangles, 1 mm elements)
    assert np.all(np.sqrt((u ** 2).mean(0)) < 10 * np.sqrt((err ** 2).mean(0)))
    assert np.all(np.sqrt((u ** 2).mean(0)) < 0.1 * np.sqrt((a.lit[m] ** 2).mean(0)))


@pytest.fixture(scope="module")
def blade_judge():
    """The blade's truth with the environment estimated at every point it is read (the pixel's and each
    element corner's own estimate, 2x the rays, other seeds): the interpolation tests' judge."""
    import skinviewer.engine.reference as R
    s, scene = _blade_under_an_environment()
    rays = 2 * R.ENV_DIFFUSE_RAYS
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(R.Surface, "env_irradiance", lambda self, t, b, energy, level="full": self.env_direct(
            self.attributes(t, b), energy, rays=rays, seed=len(t) + 11)[0])
        return compute_reference(s, h_mm=1.0, scene=scene, uncertainty=False)


def test_the_uncertainty_states_the_environments_interpolation_inside_the_triangles(monkeypatch, blade_judge):
    """compute_reference reads the environment linearly between three estimates inside each (here 3.75 mm)
    triangle, at the pixel and at the source elements (issue 30). Against the same truth with the
    environment estimated at every point it is read (the pixel's and each element corner's own estimate,
    2x the rays, other seeds), its error is within the stated uncertainty in RMS and at >= 99 % of the
    pixels in every channel; without the interpolation term (env_interpolation_uncertainty) the same
    uncertainty misses it at 30 / 5.7 / 6.0 % of the pixels. Red's wide Gaussians read the blade's far
    face 2 mm away (35 x 80 mm triangles): the term weights each triangle's check by what the Gaussians
    read there (a diffusion sum of the checks); a mean of the nearest checks (truth version 9) missed red
    at 7.4 % of the pixels. The truth is seeded, so these figures are exact here (measured: 0 / 0.55 /
    0.82 %, RMS +- / RMS error 4.2 / 4.4 / 4.2)."""
    import skinviewer.engine.reference as R
    s, scene = _blade_under_an_environment()
    a = compute_reference(s, h_mm=1.0, scene=scene)
    assert "interpolation between the three estimates" in a.meta["uncertainty"]
    assert a.meta["seconds"]["uncertainty_env_interpolation"] >= 0
    with monkeypatch.context() as mp:
        mp.setattr(R, "env_interpolation_uncertainty", lambda surf, pts, *_a, **_k: np.zeros((len(pts["P"]), 3)))
        without = compute_reference(s, h_mm=1.0, scene=scene)
    np.testing.assert_array_equal(a.lit, without.lit)  # only the uncertainty differs
    judge = blade_judge
    m = a.mask & (a.lit.sum(-1) > 0)
    assert m.sum() > 300
    err = np.abs(a.lit - judge.lit)[m]
    u, u0 = a.uncertainty[m], without.uncertainty[m]
    miss, miss0 = (err > u).mean(0), (err > u0).mean(0)
    assert np.all(miss <= 0.01), miss
    assert np.all(miss0 >= 0.05) and np.all(miss <= miss0 / 4), (miss0, miss)
    assert np.all(np.sqrt((err ** 2).mean(0)) <= np.sqrt((u ** 2).mean(0)))
    assert np.all((u >= u0).all(0))
    # not vacuous: the stated RMS under 20 % of the image's RMS and under 5x the RMS error
    assert np.all(np.sqrt((u ** 2).mean(0)) < 0.2 * np.sqrt((a.lit[m] ** 2).mean(0)))
    assert np.all(np.sqrt((u ** 2).mean(0)) < 5 * np.sqrt((err ** 2).mean(0)))


def test_the_session_truth_states_the_environments_interpolation_as_the_reference(monkeypatch, blade_judge):
    """TruthSession (the viewer's Accuracy window) states the environment read linearly between three
    estimates inside each triangle as compute_reference does (env_interpolation_sources: each triangle's
    corner checks through the same Gaussians; the delta reads the pixel's own estimate). On the blade
    under the studio sky, against the truth with the environment estimated at every point it is read
    (blade_judge), its error is within the stated uncertainty at >= 99 % of the pixels per channel and in
    RMS; the nearest checks' mean it stated before (env_element_uncertainty) missed red at 2.5 % of the
    pixels (the blade's far face, as compute_reference's version 9); measured now 0 / 0 / 0 %, RMS ± 3.6 / 4.4 / 4.3x
    the RMS error."""
    import skinviewer.engine.reference as R
    s, scene = _blade_under_an_environment()
    monkeypatch.setattr(R, "load_scene", lambda _s: scene)
    a = list(R.TruthSession(h_mm=1.0).progressive(s))[-1].reference
    assert "corners" in a.meta["uncertainty"]
    judge = blade_judge
    m = a.mask & (a.lit.sum(-1) > 0)
    assert m.sum() > 300
    err, u = np.abs(a.lit - judge.lit)[m], a.uncertainty[m]
    miss = (err > u).mean(0)
    print("misses", miss, "RMS u / RMS error", np.sqrt((u ** 2).mean(0) / (err ** 2).mean(0)))
    assert np.all(np.sqrt((err ** 2).mean(0)) > 0.005 * np.sqrt((a.lit[m] ** 2).mean(0)))  # an error worth stating
    assert np.all(miss <= 0.01), miss
    assert np.all(np.sqrt((err ** 2).mean(0)) <= np.sqrt((u ** 2).mean(0)))
    # not vacuous: the stated RMS under 20 % of the image's RMS
    assert np.all(np.sqrt((u ** 2).mean(0)) < 0.2 * np.sqrt((a.lit[m] ** 2).mean(0)))


def test_a_cached_truth_of_an_older_version_is_recomputed_with_a_note(tmp_path, monkeypatch):
    """A truth cached by an older VERSION (same inputs) is not read: compute_reference recomputes it,
    says so in meta["notes"] (`skinviewer reference` prints them), and deletes the stale file."""
    import skinviewer.engine.reference as R
    monkeypatch.setenv("SKINVIEWER_CACHE", str(tmp_path))
    s = _settings("laser", 16)
    monkeypatch.setattr(R, "VERSION", R.VERSION - 1)
    old = compute_reference(s)
    files = list((tmp_path / "reference").glob("*.npz"))
    assert len(files) == 1 and not old.meta["cached"]
    monkeypatch.undo()
    monkeypatch.setenv("SKINVIEWER_CACHE", str(tmp_path))
    new = compute_reference(s)
    assert not new.meta["cached"] and new.meta["version"] == R.VERSION
    notes = new.meta.get("notes", [])
    assert len(notes) == 1 and f"truth version {R.VERSION - 1}" in notes[0] and "recomputing" in notes[0], notes
    assert not files[0].exists()
    again = compute_reference(s)
    assert again.meta["cached"] and not again.meta.get("notes")


def test_the_refined_decision_is_reproducible():
    """refine_at under an environment (issue 30 item 4: more rays where the p99 is decided) is seeded:
    two runs from fresh surfaces give the same truth and uncertainty to the bit, so the paired p99
    verdict (metrics.p99_change_bounds) is the same; a second refinement with more environment rays
    on the same surface adds rays only up to the new factor (Surface.env_boosted) and leaves the
    refined truth's environment part no more uncertain than before."""
    from skinviewer.engine.reference import Surface, refine_at
    from skinviewer.physics.metrics import p99_change_bounds
    s, scene = _blade_under_an_environment()
    s = with_values(s, {"render.width": 20, "render.height": 20})
    ref = compute_reference(s, h_mm=1.0, scene=scene)
    m = ref.mask & (ref.lit.sum(-1) > 0)
    rel = (ref.uncertainty / np.maximum(ref.lit, 1e-3)).max(2)
    sel = m & (rel >= np.quantile(rel[m], 0.9))  # the most uncertain tenth, as the bench's tail
    assert 10 <= sel.sum() <= 60
    rng = np.random.default_rng(5)
    a = ref.lit * (1.0 + 0.05 * rng.standard_normal(ref.lit.shape))
    b = ref.lit * 1.03
    runs = []
    for _ in range(2):
        surf = Surface(*scene, s)
        runs.append((refine_at(s, ref, sel, h_mm=1.0, halvings=1, surface=surf, env_factor=2), surf))
    (r1, surf), (r2, _) = runs
    np.testing.assert_array_equal(r1.lit, r2.lit)
    np.testing.assert_array_equal(r1.uncertainty, r2.uncertainty)
    assert r1.meta["refined"]["env_factor"] == 2
    for lo_hi in zip(p99_change_bounds(a, b, r1.lit, r1.uncertainty, m), p99_change_bounds(a, b, r2.lit, r2.uncertainty, m)):
        np.testing.assert_array_equal(*lo_hi)
    boosted = surf.env_boosted.copy()
    assert set(np.unique(boosted)) <= {0, 2} and (boosted == 2).any()
    r3 = refine_at(s, ref, sel, h_mm=1.0, halvings=1, surface=surf, env_factor=8)
    assert set(np.unique(surf.env_boosted[boosted == 2])) == {8}
    assert np.all(np.isfinite(r3.lit)) and not np.array_equal(r3.lit, r1.lit)
    u1, u3 = (np.sqrt((r.uncertainty[sel] ** 2).mean(0)) for r in (r1, r3))
    assert np.all(u3 <= 1.05 * u1), (u1, u3)


def test_a_triangles_corner_checks_bound_its_mean_interpolation_error_for_a_quadratic_irradiance():
    """env_corner_checks measures a triangle's interpolation error at its corners: the three estimates sit at
    (4, 1, 1) / 6, a degree-2 quadrature's points, so for a quadratic irradiance the linear field through
    them is furthest off at the corners: their mean |error| is at least 1.6x the triangle's mean |error|
    (random triangles and quadratics), while one random point (version 9's check) is below a third of it
    about a tenth of the time."""
    import skinviewer.engine.reference as R
    rng = np.random.default_rng(3)
    u = rng.dirichlet(np.ones(3), 4000)
    ratio, one = [], []
    for _ in range(300):
        tri = rng.normal(size=(3, 2))
        c = rng.normal(size=6)

        def f(p, c=c):
            x, y = p[:, 0], p[:, 1]
            return c[0] * x * x + c[1] * y * y + c[2] * x * y + c[3] * x + c[4] * y + c[5]
        at_corners = R._ENV_W @ f(R._ENV_B @ tri)  # the linear field through the three estimates, at the corners
        mean_err = np.abs(u @ at_corners - f(u @ tri)).mean()
        ratio.append(np.abs(at_corners - f(tri)).mean() / mean_err)
        k = rng.integers(len(u))
        one.append(abs(u[k] @ at_corners - f(u[k:k + 1] @ tri)[0]) / mean_err)
    assert min(ratio) >= 1.6, min(ratio)
    assert np.mean(np.array(one) < 1 / 3) > 0.05
