"""d'Eon & Luebke's numpy maths (physics/diffusion.py, seed 000 §4.2 eq. 20-35) against independent answers:
quadrature, brute-force identities, hand-made meshes whose Jacobians are known (issue 36: its mutation group
had no fast test; the GL tests of test_deon / test_rules / test_fidelity take minutes)."""
from __future__ import annotations

import math
from types import SimpleNamespace

import numpy as np
import pytest
from scipy.integrate import quad

from skinviewer.physics import diffusion as D


def test_gaussian_and_profile_eq_20_21():
    for v in (0.01, 0.3, 4.0):
        # eq. 20 has unit integral over the plane; its peak is 1 / (2 pi v)
        assert quad(lambda r, v=v: 2 * math.pi * r * float(D.gaussian(v, r)), 0, np.inf)[0] == pytest.approx(1.0, rel=1e-9)
        assert float(D.gaussian(v, 0.0)) == pytest.approx(1.0 / (2 * math.pi * v), rel=1e-14)
        assert float(D.gaussian(v, 1.3)) == pytest.approx(math.exp(-1.69 / (2 * v)) / (2 * math.pi * v), rel=1e-14)
    # v = 0: a delta, 0 away from the centre, never NaN, also far out (no overflow, no warning)
    with np.errstate(all="raise"):
        np.testing.assert_array_equal(D.gaussian(0.0, [0.5, 1e3]), [0.0, 0.0])
        assert float(D.gaussian(1e-6, 1e3)) == 0.0
    # eq. 21 per channel, from (variance, weights) pairs or from settings terms alike
    terms = [(0.2, (1.0, 0.5, 0.0)), (1.5, (0.0, 0.5, 1.0))]
    r = np.array([[0.0, 0.4], [1.0, 2.5]])
    got = D.profile(r, terms)
    assert got.shape == (2, 2, 3)
    for c in range(3):
        want = sum(w[c] * math.exp(-r[1, 0] ** 2 / (2 * v)) / (2 * math.pi * v) for v, w in terms)
        assert got[1, 0, c] == pytest.approx(want, rel=1e-14)
    objs = [SimpleNamespace(variance=v, weights=w) for v, w in terms]
    np.testing.assert_array_equal(D.profile(r, objs), got)


def test_tsm_factor_is_the_separability_of_the_gaussian():
    """eq. 33: G(v, sqrt(r^2 + d^2)) = G(v, r) exp(-d^2 / 2v) ("exact"); the seed prints exp(-d^2 / v)."""
    for v in (0.05, 1.0, 3.0):
        for d in (0.0, 0.3, 2.0):
            for r in (0.0, 0.7):
                assert float(D.gaussian(v, math.hypot(r, d))) == pytest.approx(
                    float(D.gaussian(v, r)) * float(D.tsm_factor(d, v)), rel=1e-12)
            assert float(D.tsm_factor(d, v, "printed")) == pytest.approx(math.exp(-d * d / v), rel=1e-14)
    # v = 0: the delta passes only at zero thickness
    np.testing.assert_array_equal(D.tsm_factor([0.0, 0.1, 5.0], 0.0), [1.0, 0.0, 0.0])
    np.testing.assert_array_equal(D.tsm_factor([0.0, 0.1], [0.0, 0.0], "printed"), [1.0, 0.0])


def test_seven_tap_kernel_has_unit_variance_and_listing_14_5_does_not():
    k = D.KERNEL7
    assert k.shape == (7,) and k.sum() == pytest.approx(1.0, abs=1e-15)
    np.testing.assert_allclose(k, k[::-1], rtol=0, atol=1e-17)
    assert float(np.sum(k * np.arange(-3, 4) ** 2)) == pytest.approx(1.0, abs=1e-12)
    # the figures the module quotes: s = 1.0021, weights 0.0045, 0.0543, 0.2420, 0.3982 (it said 1.0008 and
    # 0.0044, 0.0540, 0.2420, 0.3991 -- the plain s = 1 Gaussian's -- until this test)
    np.testing.assert_allclose(k[:4], [0.0045, 0.0543, 0.2420, 0.3982], atol=5e-5)
    s = math.sqrt(-1.0 / (2.0 * math.log(k[4] / k[3])))  # w_1 / w_0 = exp(-1 / 2 s^2)
    assert s == pytest.approx(1.0021, abs=1e-4)
    np.testing.assert_allclose(k, np.exp(-np.arange(-3, 4) ** 2 / (2 * s * s)) / np.exp(-np.arange(-3, 4) ** 2 / (2 * s * s)).sum(),
                               rtol=1e-12)
    assert float(np.sum(D.GPU_GEMS_KERNEL7 * np.arange(-3, 4) ** 2)) == pytest.approx(1.08, abs=0.005)
    # the solver itself (KERNEL7 is computed once, at import): the same kernel when called again
    np.testing.assert_allclose(D._solve_kernel(), k, rtol=1e-12)


def test_blur_plan_chain_reuse_fold_and_texels():
    """eq. 24: blur_i = blur_(i-1) (x) G(v_i - var(blur_(i-1))); worked by hand."""
    v = [0.01, 0.05, 0.04, 0.3]
    plan = D.blur_plan(v, reuse_below=0.02)
    B = D.BlurStep
    assert plan == [B(0, "deon_irradiance", 0.0, 0.0, True),      # v_1 < reuse: the irradiance itself
                    B(1, "deon_irradiance", 0.05, 0.05, False),   # measured from what the source has (0)
                    B(2, "blur_1", 0.0, 0.05, False),             # non-ascending: adds nothing
                    B(3, "blur_2", 0.25, 0.3, False)]
    assert [D.texture_of(s) for s in plan] == ["deon_irradiance", "blur_1", "blur_2", "blur_3"]
    # the first Gaussian is blurred when it is at the threshold (not below it)
    assert D.blur_plan([0.02], reuse_below=0.02) == [B(0, "deon_irradiance", 0.02, 0.02, False)]
    # folding: a later increment under fold_below is skipped and the next real step adds it back
    plan = D.blur_plan([0.1, 0.12, 0.5, 0.51], reuse_below=0.0, fold_below=0.05)
    assert plan == [B(0, "deon_irradiance", 0.1, 0.1, False), B(1, "blur_0", 0.0, 0.1, True),
                    B(2, "blur_0", 0.4, 0.5, False), B(3, "blur_2", 0.0, 0.5, True)]
    assert [D.texture_of(s) for s in plan] == ["blur_0", "blur_0", "blur_2", "blur_2"]
    # an increment exactly at fold_below is blurred; a negative variance counts as 0
    assert D.blur_plan([0.25, 0.5], 0.0, 0.25)[1] == B(1, "blur_0", 0.25, 0.5, False)
    assert D.blur_plan([-1.0, 0.2], 0.0)[0] == B(0, "deon_irradiance", 0.0, 0.0, False)
    # texel-relative thresholds: (k texels)^2; negative k is 0
    t = 0.1
    assert D.blur_plan_texels([0.0099, 0.02], 1.0, t) == D.blur_plan([0.0099, 0.02], 0.01)
    assert D.blur_plan_texels([0.01, 0.0105], 0.0, t, fold_below_texels=0.5)[1].reused
    assert not D.blur_plan_texels([0.01, 0.0105], 0.0, t, fold_below_texels=-3.0)[1].reused
    assert D.blur_plan_texels([0.001], -2.0, t)[0].reused is False
    assert D.blur_resource(3) == "blur_3" and D.stretch_blur_resource(2) == "stretch_blur_2"


def _affine_mesh(M, uvs, mm=1.0):
    """Positions P = M @ (u, v): the Jacobian dP/du, dP/dv is M's columns (times mm per unit)."""
    uvs = np.asarray(uvs, np.float64)
    return uvs @ np.asarray(M, np.float64).T, uvs


def test_uv_jacobians_covariance_and_stretch_on_affine_meshes():
    """On an affine map P = M (u, v) every triangle's Jacobian is M (mm): S = (M^T M)^-1, the surface area
    is |M_u x M_v| x the UV area, the shear is the angle between M's columns; checked with numpy's inverse
    and cross product (seed 000 eq. 27 without dropping the shear)."""
    a = math.radians(70.0)
    M = np.array([[2.0, 3.0 * math.cos(a)], [0.0, 3.0 * math.sin(a)], [0.0, 0.0]])  # |M_u| 2, |M_v| 3, 70 deg
    uv = [[0.0, 0.0], [0.5, 0.0], [0.0, 0.25], [0.5, 0.25]]
    P, T = _affine_mesh(M, uv)
    idx = np.array([[0, 1, 2], [1, 3, 2]])
    mm = 10.0
    pu, pv, ok = D.uv_jacobians(P, T, idx, mm)
    assert ok.all()
    np.testing.assert_allclose(pu, [M[:, 0] * mm] * 2, atol=1e-12)
    np.testing.assert_allclose(pv, [M[:, 1] * mm] * 2, atol=1e-12)
    J = M * mm
    Sinv = np.linalg.inv(J.T @ J)
    S, ok2, area = D.triangle_uv_covariance(P, T, idx, mm)
    np.testing.assert_allclose(S, [[Sinv[0, 0], Sinv[0, 1], Sinv[1, 1]]] * 2, rtol=1e-12)
    surf = np.linalg.norm(np.cross(J[:, 0], J[:, 1])) * 0.5 * 0.125  # |J_u x J_v| x each triangle's UV area
    np.testing.assert_allclose(area, [surf, surf], rtol=1e-12)
    assert ok2.all()
    assert D.max_uv_per_mm(P, T, idx, mm) == pytest.approx(math.sqrt(max(Sinv[0, 0], Sinv[1, 1])), rel=1e-12)
    assert D.max_shear_cos(P, T, idx, mm) == pytest.approx(math.cos(a), rel=1e-12)
    # isotropic scale of the whole mesh: sqrt(UV area / world area in mm^2)
    world = np.linalg.norm(np.cross(M[:, 0], M[:, 1])) * 0.125 * mm * mm
    assert D.uniform_uv_per_mm(P, T, idx, mm) == pytest.approx(math.sqrt(0.125 / world), rel=1e-12)
    # per vertex: the area-weighted mean of its triangles' S (here equal: S itself); as float32
    Sv = D.vertex_uv_covariance(P, T, idx, mm)
    assert Sv.dtype == np.float32 and Sv.shape == (4, 3)
    np.testing.assert_allclose(Sv, [[Sinv[0, 0], Sinv[0, 1], Sinv[1, 1]]] * 4, rtol=1e-6)
    # the stretch map back from S: s_u = 1 / sqrt(G_uu), s_v = 1 / sqrt(G_vv), c = G_uv / sqrt(G_uu G_vv)
    G = J.T @ J
    st = D.stretch_from_uv_covariance(S[0])
    np.testing.assert_allclose(st, [1 / math.sqrt(G[0, 0]), 1 / math.sqrt(G[1, 1]),
                                    G[0, 1] / math.sqrt(G[0, 0] * G[1, 1])], rtol=1e-12)
    assert st[2] == pytest.approx(math.cos(a), rel=1e-12)


def test_vertex_covariance_weights_by_surface_area_and_degenerate_meshes_get_the_clamp():
    # two triangles meeting at vertex 1: one with J = diag(1, 1) mm, one with J = diag(2, 2) mm and 4x the area
    P = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [3, 0, 0], [1, 2, 0]], np.float64)
    T = np.array([[0, 0], [1, 0], [0, 1], [2, 0], [1, 1]], np.float64)
    idx = np.array([[0, 1, 2], [1, 3, 4]])
    S, ok, area = D.triangle_uv_covariance(P, T, idx, 1.0)
    np.testing.assert_allclose(area, [0.5, 2.0], rtol=1e-12)
    np.testing.assert_allclose(S, [[1, 0, 1], [0.25, 0, 0.25]], rtol=1e-12, atol=1e-15)
    Sv = D.vertex_uv_covariance(P, T, idx, 1.0)
    np.testing.assert_allclose(Sv[1], [(0.5 * 1 + 2 * 0.25) / 2.5, 0, (0.5 * 1 + 2 * 0.25) / 2.5], rtol=1e-6)
    np.testing.assert_allclose(Sv[[0, 2]], [[1, 0, 1]] * 2, rtol=1e-6)
    np.testing.assert_allclose(Sv[[3, 4]], [[0.25, 0, 0.25]] * 2, rtol=1e-6)
    lim = D.MAX_UV_PER_MM ** 2
    # a triangle with UV area but no surface (collapsed in 3-D): the clamp, area 0; a UV-degenerate one: not ok
    Pz = np.array([[0, 0, 0], [1, 0, 0], [2, 0, 0]], np.float64)
    S, ok, area = D.triangle_uv_covariance(Pz, T[:3], np.array([[0, 1, 2]]), 1.0)
    assert ok.all() and area[0] == 0.0
    np.testing.assert_array_equal(S, [[lim, 0.0, lim]])
    np.testing.assert_allclose(D.vertex_uv_covariance(Pz, T[:3], np.array([[0, 1, 2]]), 1.0), [[lim, 0, lim]] * 3)
    Tflat = np.array([[0, 0], [1, 0], [2, 0]], np.float64)
    pu, pv, ok = D.uv_jacobians(P[:3], Tflat, np.array([[0, 1, 2]]), 1.0)
    assert not ok.any() and np.all(pu == 0) and np.all(pv == 0)
    assert D.max_uv_per_mm(P[:3], Tflat, np.array([[0, 1, 2]]), 1.0) == D.MAX_UV_PER_MM
    assert D.max_shear_cos(P[:3], Tflat, np.array([[0, 1, 2]]), 1.0) == 0.0
    assert D.uniform_uv_per_mm(P[:3], Tflat, np.array([[0, 1, 2]]), 1.0) == 1.0
    assert D.uniform_uv_per_mm(Pz, T[:3], np.array([[0, 1, 2]]), 1.0) == 1.0
    # a tiny surface triangle (S far over the clamp) is scaled down to the clamp on its largest axis
    S, ok, _ = D.triangle_uv_covariance(P[:3] * 1e-3, T[:3], np.array([[0, 1, 2]]), 1.0)
    np.testing.assert_allclose(S, [[lim, 0.0, lim]], rtol=1e-9)
    # the stretch of a non-positive-definite S is the clamp; the shear is clamped to +-0.95
    np.testing.assert_array_equal(D.stretch_from_uv_covariance([1.0, 2.0, 1.0]), [D.MAX_UV_PER_MM] * 2 + [0.0])
    np.testing.assert_array_equal(D.stretch_from_uv_covariance([0.0, 0.0, 1.0]), [D.MAX_UV_PER_MM] * 2 + [0.0])
    assert D.stretch_from_uv_covariance([1.0, -0.99, 1.0])[2] == 0.95
    assert D.stretch_from_uv_covariance([1.0, 0.99, 1.0])[2] == -0.95
    # s_u, s_v clamped into [1e-7, MAX_UV_PER_MM]
    np.testing.assert_allclose(D.stretch_from_uv_covariance([1e6, 0.0, 1e-20])[:2], [D.MAX_UV_PER_MM, 1e-7])
    np.testing.assert_allclose(D.stretch_from_uv_covariance([1e-20, 0.0, 1e6])[:2], [1e-7, D.MAX_UV_PER_MM])


def test_sub_steps_add_up_and_keep_each_blur_smooth():
    """The variances add up to the increment exactly (eq. 24) and each sub-blur's sigma is at most
    s_k / SMOOTH_RATIO, s_k^2 = max(sigma_in, texel / 2)^2 + the earlier sub-blurs' variances."""
    for sigma_in, inc, texel in ((0.0, 1.0, 0.01), (0.05, 0.4, 0.02), (0.3, 0.01, 0.1), (0.0, 2.0, 0.0)):
        out = D.sub_steps(sigma_in, inc, texel)
        assert sum(s * s for s in out) == pytest.approx(inc, rel=1e-12)
        s2 = max(sigma_in, 0.5 * texel) ** 2
        for s in out[:-1]:
            assert s == pytest.approx(math.sqrt(s2) / D.SMOOTH_RATIO, rel=1e-12)
            s2 += s * s
        assert len(out) <= 8
        if s2 > 0:
            assert out[-1] <= math.sqrt(s2) / D.SMOOTH_RATIO * (1 + 1e-12) or len(out) == 8
    assert D.sub_steps(0.1, 1.0, 0.01, max_steps=3).__len__() == 3
    assert D.sub_steps(0.1, 0.0, 0.01) == [0.0] and D.sub_steps(0.1, -1.0, 0.01) == [0.0]
    assert D.sub_steps(0.0, 0.5, 0.0) == [math.sqrt(0.5)]  # nothing to be smooth against: one blur
    assert D.sub_steps(0.5, 0.09, 0.01) == [pytest.approx(0.3)]  # already smooth enough: one blur
    # geometric growth by hand: sigma_in 0.06 (SMOOTH_RATIO 0.6: cap = s^2 / 0.36), inc 0.1
    assert D.sub_steps(0.06, 0.1, 0.0) == [pytest.approx(0.1), pytest.approx(math.sqrt(0.0136 / 0.36)),
                                           pytest.approx(math.sqrt(0.1 - 0.01 - 0.0136 / 0.36))]


def test_profile_variance_is_the_profiles_second_moment_by_quadrature():
    variances = [0.05, 0.4, 2.0]
    weights = [(0.5, 0.2, 0.0), (0.3, 0.5, 0.0), (0.2, 0.3, 0.0)]
    got = D.profile_variance(variances, weights)
    for c in range(2):
        def prof(r, p=0, c=c):
            return sum(w[c] * math.exp(-r * r / (2 * v)) / (2 * math.pi * v) for v, w in zip(variances, weights)) * r ** p
        mass = quad(lambda r: 2 * math.pi * r * prof(r), 0, np.inf)[0]
        assert got[c] == pytest.approx(quad(lambda r: 2 * math.pi * r * prof(r, 2), 0, np.inf)[0] / mass / 2, rel=1e-9)
    assert got[2] == 0.0  # no energy: 0, not NaN
