"""Pre-integrated skin (Penner & Borshukov 2011; physics/penner.py, shaders/penner.frag): the ring table
against a brute-force ring integral, its limits, the penumbra table, the mesh's curvature, and the
shader against its numpy twin on a sphere of known radius."""
from __future__ import annotations

import math

import numpy as np
import pytest
from helpers import small_settings

from skinviewer.ground.settings import Settings, with_values
from skinviewer.physics import penner

GS = [(g.variance, tuple(g.weights)) for g in Settings().deon.gaussians]


@pytest.mark.parametrize("row,col", [(1, 33), (5, 20), (30, 40), (63, 10), (40, 63)])
def test_ring_table_equals_the_ring_integral(row, col):
    n, kmax = 64, 2.0
    lut = penner.ring_lut(GS, n, kmax)
    k, ndl = (row + 0.5) / n * kmax, (col + 0.5) / n * 2 - 1
    exact = penner.ring_integral(GS, math.acos(ndl), 1.0 / k)  # 200001 samples over the whole ring
    # the table integrates each Gaussian over its own support with 257 samples: measured 4e-4 relative
    assert lut[row, col] == pytest.approx(exact, rel=2e-3, abs=1e-7)


def test_ring_table_limits_flat_skin_and_no_light_from_nowhere():
    lut = penner.ring_lut(GS, 64, 0.05)  # radii of 20 mm and more: the profile sees a plane
    ndl = (np.arange(64) + 0.5) / 64 * 2 - 1
    assert np.abs(lut[0] - np.maximum(ndl, 0)[:, None]).max() < 2e-3
    hot = penner.ring_lut(GS, 64, 20.0)
    assert hot.min() >= 0.0 and hot.max() <= 1.0  # an average of max(cos, 0): never above 1
    # light wraps past the terminator, furthest in red (the widest profile)
    back = penner.ring_lut(GS, 64, 2.0)[32, 25]  # N.L = -0.2 on a 1 mm radius
    assert back[0] > back[1] > back[2] > 0.0


def test_penumbra_table_keeps_its_ends_and_bleeds_red_into_the_shadow():
    lut = penner.penumbra_lut(GS, 32, 8.0)
    assert np.all(np.diff(lut, axis=1) >= -1e-6)  # monotone in the shadow value
    assert lut[:, 0].max() < 0.02 and lut[:, -1].min() > 0.98  # s -> 0 stays dark, s -> 1 stays lit
    dark = lut[4, 4]  # a quarter into a 1.1 mm penumbra, on its shadowed side
    assert dark[0] > dark[1] > dark[2]


def test_vertex_curvature_is_one_over_the_radius():
    import trimesh
    sphere = trimesh.creation.icosphere(4, 10.0)
    k = penner.vertex_curvature(sphere.vertices, sphere.vertex_normals, sphere.faces, 1.0)
    assert k == pytest.approx(np.full(len(k), 0.1), rel=0.02)
    k48 = penner.vertex_curvature(sphere.vertices, sphere.vertex_normals, sphere.faces, 48.0)
    assert k48 == pytest.approx(k / 48.0, rel=1e-5)  # curvature is per millimetre
    plane = trimesh.creation.box((10, 10, 0.001))
    top = plane.vertex_normals  # a box's corners bend; its flat faces' edges do not
    kp = penner.vertex_curvature(plane.vertices, np.tile([0, 0, 1.0], (8, 1)), plane.faces, 1.0)
    assert kp.max() == 0.0 and top.shape == (8, 3)


RADIUS = 1.0  # mm: red's profile wraps far around it


def test_shader_agrees_with_its_numpy_twin_on_a_sphere(renderer, tmp_path):
    """A 1 mm sphere under one unshadowed light, no specular, no energy term: every pixel of the
    technique is C Lc D(N.L, 1/R), with N.L read from Phong's Lambert image of the same frame."""
    import trimesh
    path = tmp_path / "sphere.obj"
    trimesh.creation.icosphere(5, RADIUS).export(path)
    light = {"kind": "directional", "direction": (0.3, 0.2, 1.0), "intensity": 1.0, "color": (1, 1, 1),
             "cast_shadow": False}
    base = small_settings("head", "penner", 96, **{"scene.mesh": str(path), "scene.mm_per_unit": 1.0,
                                                   "lights": [light], "specular.rho_s": 0.0,
                                                   "deon.energy_conservation": False,
                                                   "phong.ambient": 0.0, "phong.specular": 0.0})
    renderer.render(base)
    got = renderer.read(base, "lit")[..., :3].astype(np.float64)
    ph = with_values(base, {"technique": "phong"})
    renderer.render(ph)
    lambert = renderer.read(ph, "lit")[..., :3].astype(np.float64)  # C * max(N.L, 0)
    C = renderer.ensure_scene(base).gpu.albedo.read()  # 1x1 default skin tone, linear, f2
    C = np.frombuffer(C, np.float16).astype(np.float64)[:3]
    ndl = lambert[..., 1] / C[1]
    mask = (ndl > 0.05) & (ndl < 0.95)
    assert mask.sum() > 500
    n, kmax = base.penner.lut_size, base.penner.max_curvature
    lut = penner.ring_lut(GS, n, kmax)
    # bilinear, as the sampler: rows at k / kmax = (1 / R) / kmax, columns at N.L * 0.5 + 0.5
    t = (1 / RADIUS) / kmax * n - 0.5
    r0 = int(math.floor(t))
    row = lut[r0] * (1 - (t - r0)) + lut[r0 + 1] * (t - r0)
    cols = (np.arange(n) + 0.5) / n
    expect = np.stack([np.interp(ndl[mask] * 0.5 + 0.5, cols, row[:, c]) for c in range(3)], -1) * C
    err = np.abs(got[mask] - expect) / expect.max()
    # f16 images and the sphere's facets: measured 0.25 % of the peak at most, 0.01 % median
    assert err.max() < 0.01 and np.median(err) < 0.001
    assert np.abs(got[mask] - lambert[mask]).max() > 0.02  # and it differs from Lambert: it wraps


def test_technique_renders_the_head_finite_and_softer_than_phong(renderer):
    s = small_settings("head", "penner", 64)
    rep = renderer.render(s)
    assert "penner" in rep.ran and "penner_luts" in rep.ran
    img = renderer.read(s, "lit")
    assert np.isfinite(img).all() and img[..., :3].max() > 0.05
    again = renderer.render(with_values(s, {"camera.yaw": 20.0}))
    assert "penner_luts" not in again.ran  # the tables depend on the profile, not on the camera


def test_shadow_factor_and_the_penumbra_table(renderer):
    """The shadow term P of penner.frag on the shadow-edge scene (a blade's shadow on a plane), with a
    coarse map and a wide PCF so the edge has a penumbra. The PCF value s of each pixel is read from
    Phong's image of the same frame (its diffuse is C Lc s N.L: s = shadowed / unshadowed). Without the
    penumbra table the diffuse is exactly s times the unshadowed one; with it, the umbra (s = 0) stays
    black, the lit side (s = 1) is the unshadowed image, and the penumbra bleeds red furthest."""
    a = {"shadow.map_size": 64, "shadow.pcf": 3, "specular.rho_s": 0.0, "phong.ambient": 0.0,
         "phong.specular": 0.0, "deon.energy_conservation": False}
    base = small_settings("shadow-edge", "phong", 64, **a)

    def lit(s):
        renderer.render(s)
        return renderer.read(s, "lit")[..., :3].astype(np.float64)

    def unshadowed(s):
        return with_values(s, {"lights.0.cast_shadow": False})

    ph_off = lit(unshadowed(base))
    m = ph_off[..., 1] > 0.02
    s = lit(base)[..., 1][m] / ph_off[..., 1][m]
    umbra, lit_side, pen = s == 0.0, s > 0.999, (s > 0.05) & (s < 0.95)
    assert umbra.sum() > 100 and lit_side.sum() > 100 and pen.sum() > 50
    hard = with_values(base, {"technique": "penner", "penner.penumbra": False})
    off = lit(unshadowed(hard))[m]
    got = lit(hard)[m]
    # f16 images of values below 0.8 (an ulp is 4.9e-4); measured 5.5e-4 at most
    np.testing.assert_allclose(got, s[:, None] * off, atol=2e-3)
    soft = lit(with_values(hard, {"penner.penumbra": True}))[m]
    assert np.all(soft[umbra] == 0.0)
    np.testing.assert_allclose(soft[lit_side], off[lit_side], atol=2e-3)
    p = soft[pen] / np.maximum(off[pen], 1e-6)  # the table's P per channel
    assert np.all(p >= -1e-3) and np.all(p <= 1.0 + 2e-3)
    assert np.mean(p[:, 0] - p[:, 2]) > 0.02  # red scatters furthest into the shadow
    assert np.abs(p[:, 0] - s[pen]).max() > 0.05  # the table, not s itself


def test_env_band_factors_by_funk_hecke_on_closed_form_rows():
    """Issue 36 (penner's mutation group had no numpy test of env_band_factors). Funk-Hecke on rows whose
    band weights are known in closed form, against the clamped cosine's (lambda_0 = 1/2, lambda_1 = 1/3,
    lambda_2 = 1/8 of int_-1^1 P_l(mu) max(mu, 0) dmu): the flat row max(mu, 0) gives 1, 1, 1; wrap lighting
    (1 + mu) / 2 gives 1 / (1/2) = 2, (1/3) / (1/3) = 1, 0 / (1/8) = 0; a constant 1/2 gives 2, 0, 0.
    Midpoint rule over 512 columns: O(1/n^2), measured < 1e-5."""
    n = 512
    mu = (np.arange(n) + 0.5) / n * 2.0 - 1.0
    rows = np.stack([np.maximum(mu, 0.0), 0.5 * (1.0 + mu), np.full(n, 0.5)])  # (3 rows, n)
    ring = np.repeat(rows[:, :, None], 3, axis=2)
    ring[:, :, 2] *= 0.5  # blue at half: the factors are ratios of the same rule, unchanged
    w = penner.env_band_factors(ring)
    assert w.shape == (3, 3, 3) and w.dtype == np.float32
    want = np.array([[1.0, 1.0, 1.0], [2.0, 1.0, 0.0], [2.0, 0.0, 0.0]])
    np.testing.assert_allclose(w[:, :, 0], want, atol=2e-5)
    np.testing.assert_allclose(w[:, :, 1], want, atol=2e-5)
    np.testing.assert_allclose(w[:, :, 2], want * 0.5, atol=2e-5)


def test_vertex_curvature_of_one_bent_triangle_by_hand():
    """|n_i - n_j| / |p_i - p_j| on each of the three edges, averaged per vertex (a sphere cannot tell
    a missing edge: every edge gives 1/R there)."""
    p = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
    nrm = np.array([[0.0, 0.0, 1.0], [0.6, 0.0, 0.8], [0.0, 0.0, 1.0]])
    k01, k12, k02 = math.sqrt(0.4), math.sqrt(0.4) / math.sqrt(2.0), 0.0
    got = penner.vertex_curvature(p, nrm, np.array([[0, 1, 2]]), 2.0)  # 2 mm per unit: halves every k
    np.testing.assert_allclose(got, [(k01 + k02) / 4, (k01 + k12) / 4, (k12 + k02) / 4], rtol=1e-6)


def _lit_and_ss_diffuse(renderer, technique: str, scene: str, **assign):
    s = small_settings(scene, technique, 96, **{"deon.energy_conservation": False, "screen.texturing": "pre",
                                                 **assign})
    renderer.render(s)
    g = renderer.graph(technique)
    return g.read("lit" if technique == "penner" else "ss_diffuse").astype(np.float64)[..., :3]


@pytest.mark.parametrize("translucency", [0.0, 0.5])
def test_transmittance_through_the_ear_is_the_screen_space_techniques_own(renderer, translucency):
    """A back-lit ear glows in pre-integrated skin (it was black): Jimenez 2010's transmittance through
    the same lib/tr_thickness.glsl and lib/tr_profile.glsl as ssss, so what the transmittance adds to
    Penner's image equals what it adds to ssss's pre-blur diffuse (pre-scatter texturing, no rho_dt:
    both are albedo x the transmitted light)."""
    def added(t):
        on = _lit_and_ss_diffuse(renderer, t, "backlit-ear", **{"transmittance.translucency": translucency})
        off = _lit_and_ss_diffuse(renderer, t, "backlit-ear", **{"transmittance.enabled": False})
        return on - off
    pen, ss = added("penner"), added("ssss")
    lit = ss.max(axis=-1) > 1e-3
    assert lit.sum() > 500  # the ear transmits over many pixels
    assert np.isfinite(pen).all() and pen.min() > -1e-3
    # penner's lit is half-float: 2^-11 relative, plus its rounding of the 'off' image
    assert np.abs(pen - ss)[lit].max() <= 2e-3 * ss.max() + 1e-3 * np.abs(ss)[lit].max()
    assert (pen[~lit] < 1e-3).all()  # no light from nowhere where ssss transmits none
