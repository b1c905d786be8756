"""tests/analytic_judge.py (the measurements behind benchmarks/bench_accuracy.py) on synthetic data:
no GL, fast. The benchmark's timings are never asserted."""
from __future__ import annotations

import math

import analytic_judge as A
import numpy as np
import pytest

from skinviewer.ground.settings import DeonSettings
from skinviewer.physics.poisson import POISSON_12
from skinviewer.physics.profiles import sum_of_gaussians
from skinviewer.scene.scenes import laser_scene

V = np.array([g.variance for g in DeonSettings().gaussians])
W = np.array([g.weights for g in DeonSettings().gaussians])


def _laser_grid(n=256):
    m = laser_scene().mesh
    return A.plane_coords(m.positions, m.uvs, m.mm_per_unit, n)


def _beam(X, spots):
    """Irradiance with the given (row, col, power) texels lit (RGB alike)."""
    E = np.zeros(X.shape + (3,))
    for i, j, p in spots:
        E[i, j] = p
    return E


def _exact(E, X, Y, area, v, w):
    """sum over lit texels of power * sum_i w_i G(v_i, |x - x_lit|), computed independently."""
    D = np.zeros(X.shape + (3,))
    for i, j in zip(*np.nonzero(E[..., 0] > 0)):
        D += E[i, j] * area * sum_of_gaussians(np.hypot(X - X[i, j], Y - Y[i, j]), v, w)
    return D


def test_plane_coords_of_the_laser_slab():
    X, Y, area = _laser_grid(256)
    m = laser_scene().mesh
    du, dv = A.texel_mm(m.positions, m.uvs, m.mm_per_unit, 256)
    assert du == pytest.approx(25.0 / 256) and dv == pytest.approx(25.0 / 256)  # 24 mm over uv 0.96
    assert area == pytest.approx(du * dv)
    assert X[0, 127] < 0 < X[0, 128] and Y[127, 0] < 0 < Y[128, 0]
    assert X[0, 128] == pytest.approx(0.5 * du)


@pytest.mark.parametrize("spots", [[(128, 128, 1.0)], [(127, 127, 2.0), (127, 128, 1.0), (128, 128, 0.5)]])
def test_exact_profile_has_no_error(spots):
    X, Y, area = _laser_grid()
    E = _beam(X, spots)
    D = _exact(E, X, Y, area, V, W)
    e = A.laser_errors(D, E, X, Y, area, V, W)
    assert np.all(e["l1"] < 1e-9) and np.all(e["eq31"] < 1e-9), e
    assert np.allclose(e["power"], sum(p for *_, p in spots) * area)
    # a 24 mm slab holds all but the far red tail of the profile
    assert np.allclose(e["kept"], 1.0, atol=2e-3), e["kept"]


def test_scaled_profile_error_is_the_scale():
    X, Y, area = _laser_grid()
    E = _beam(X, [(128, 128, 1.0)])
    e = A.laser_errors(1.1 * _exact(E, X, Y, area, V, W), E, X, Y, area, V, W)
    np.testing.assert_allclose(e["l1"], 0.1, rtol=1e-9)
    np.testing.assert_allclose(e["eq31"], 0.1, rtol=1e-9)
    np.testing.assert_allclose(e["kept"], 1.1, atol=3e-3)


def test_wrong_profiles_have_large_errors():
    X, Y, area = _laser_grid()
    E = _beam(X, [(128, 128, 1.0)])
    wide = A.laser_errors(_exact(E, X, Y, area, 2.0 * V, W), E, X, Y, area, V, W)
    assert np.all(wide["l1"] > 0.2) and np.all(wide["eq31"] > 0.3), wide
    # no scattering at all: the lit texel itself (Phong) -- mass in the wrong place, twice over
    delta = A.laser_errors(E, E, X, Y, area, V, W)
    assert np.all(delta["l1"] > 0.9) and np.all(delta["eq31"] > 1.0), delta
    # two Gaussians fitted to the profile: worse than the six, but far better than no scattering
    from skinviewer.physics.fitting import fit_gaussians
    from skinviewer.physics.profiles import deon_skin_profile
    f = fit_gaussians(deon_skin_profile, 2, max_starts=2)
    two = A.laser_errors(_exact(E, X, Y, area, f.variances, f.weights), E, X, Y, area, V, W)
    assert np.all(two["l1"] > 0.01) and np.all(two["l1"] < delta["l1"]), two


def test_reference_needs_a_lit_texel():
    X, Y, area = _laser_grid(64)
    with pytest.raises(ValueError):
        A.profile_reference(np.zeros(X.shape + (3,)), X, Y, area, V, W)


def test_profile_variance():
    var = A.profile_variance(V, W)
    np.testing.assert_allclose(var, (W * V[:, None]).sum(0) / W.sum(0))
    assert var[0] == pytest.approx(1.38, abs=0.01) and var[0] > var[1] > var[2]


def test_deon_blur_passes_follow_the_plan():
    # reused first Gaussian: no blur; the rest at least one 7-tap blur each
    p = A.deon_blur_passes(V, 0.01, 25.0 / 1024)
    assert p[0] == 0 and all(k >= 1 for k in p[1:])
    q = A.deon_blur_passes(V, 0.0, 25.0 / 1024)
    assert q[0] >= 1
    assert sum(A.deon_blur_passes(V, 0.0, 25.0 / 256)) <= sum(q)  # coarser texels: smoother, fewer sub-steps


def test_poisson_kernel_1d():
    offs, w = A.poisson_kernel_1d(0.0)
    assert list(offs[w > 0]) == [0] and w.sum() == pytest.approx(1.0)
    px = np.array(POISSON_12)[:, 0]
    for R in (0.5, 3.0, 7.3):
        offs, w = A.poisson_kernel_1d(R)
        assert w.sum() == pytest.approx(1.0) and np.all(w >= 0)
        d = px * R
        f = d - np.floor(d)
        mean = d.sum() / 13
        expect = (np.sum(d * d + f * (1 - f)) / 13) - mean ** 2  # bilinear taps add f(1-f)
        assert A.kernel_variance(offs, w) == pytest.approx(expect, rel=1e-9)
        o4, w4 = A.iterate_kernel(offs, w, 4)
        assert A.kernel_variance(o4, w4) == pytest.approx(4 * expect, rel=1e-9)
        assert w4.sum() == pytest.approx(1.0)
    assert A.iterate_kernel(offs, w, 0)[1].tolist() == [1.0]


def test_erf_edge_helpers():
    x = np.arange(200, dtype=float)
    for sigma in (1.5, 6.0, 20.0):
        t = A.erf_edge(x, 100.3, sigma)
        assert A.edge_position(t) == pytest.approx(100.3, abs=0.05 * sigma)
        assert A.fit_erf_sigma(x, t, 100.3) == pytest.approx(sigma, rel=1e-4)
        # linear interpolation between samples widens a sharp edge a little (5 % at sigma 1.5 samples)
        assert A.width_10_90(t) == pytest.approx(A.GAUSS_10_90 * sigma, rel=0.06 if sigma < 2 else 0.01)
    step = A.erf_edge(x, 99.5, 0.0)
    assert step[99] == 0 and step[100] == 1 and A.width_10_90(step) <= 1.0


def test_iterated_poisson_edge_tends_to_the_equal_variance_erf():
    # the blur the benchmark measures on the GPU, in numpy: a step, n Poisson iterations
    x = np.arange(400, dtype=float)
    step = A.erf_edge(x, 199.5, 0.0)
    k1 = A.poisson_kernel_1d(6.0)
    errs = []
    for n in (1, 2, 4, 8):
        kn = A.iterate_kernel(*k1, n)
        sig = math.sqrt(A.kernel_variance(*kn))
        edge = A.apply_kernel_1d(step, *kn)
        errs.append(float(np.max(np.abs(edge - A.erf_edge(x, 199.5, sig)))))
    assert errs[0] > 0.02 and errs[-1] < 0.01 and errs[-1] < errs[0], errs


def test_eq31_over_the_plane_matches_radial_integral():
    # for a radial function eq. 3.1 over texels equals the 1D r-weighted integral form
    n = 512
    c = (np.arange(n) + 0.5) / n * 20.0 - 10.0
    X, Y = np.meshgrid(c, c)
    R = np.hypot(X, Y)
    ref = sum_of_gaussians(R, V, W)
    D = sum_of_gaussians(R, 1.2 * V, W)
    got = A.eq31_error(D, ref, R, 9.0)
    r = np.linspace(1e-4, 9.0, 20001)
    a, b = sum_of_gaussians(r, V, W), sum_of_gaussians(r, 1.2 * V, W)
    want = np.sqrt(np.trapezoid(r[:, None] * (b - a) ** 2, r, axis=0) / np.trapezoid(r[:, None] * a ** 2, r, axis=0))
    np.testing.assert_allclose(got, want, rtol=0.03)
