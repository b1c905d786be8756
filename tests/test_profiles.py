"""Profile models: dipole closed form, multipole limits and layering, Burley normalisation and its
CDF / analytic inverse (seed 001 eq. 2.59-2.89, 3.9, 3.12-3.13), hard cases."""
import math

import numpy as np
import pytest

from skinviewer.physics import profiles as P

R_LOG = np.geomspace(1e-7, 1e5, 120001)


def plane_integral(R, r=R_LOG):
    """2 pi int r R dr on a log grid (trapezoid in log r)."""
    return 2 * math.pi * np.trapezoid(r[:, None] ** 2 * R, np.log(r), axis=0)


@pytest.mark.parametrize("name", ["Marble", "Skin1", "Ketchup", "Spectralon", "Apple"])
def test_dipole_total_reflectance_matches_jensen_closed_form(name):
    m = P.MATERIALS[name].dipole()
    a = m.c.alpha_prime
    t = np.sqrt(3 * (1 - a))
    closed = a / 2 * (1 + np.exp(-4 / 3 * m.A * t)) * np.exp(-t)  # Jensen 2001 alpha' -> R_d
    np.testing.assert_allclose(plane_integral(m(R_LOG)), closed, rtol=2e-4)
    np.testing.assert_allclose(m.total_reflectance(), closed, rtol=1e-12)
    np.testing.assert_allclose(m.hankel(0.0), closed, rtol=1e-12)


def test_dipole_values_and_shape():
    m = P.MATERIALS["Marble"].dipole()
    assert m(np.zeros((2, 5))).shape == (2, 5, 3)
    # eq. 2.59 at r = 0: alpha'/(4pi) [(1 + s z_r)e^{-s z_r}/z_r^2 + (1 + s z_v)e^{-s z_v}/z_v^2]
    s, zr, zv = m.c.sigma_tr, m.z_r, m.z_v
    ref = m.c.alpha_prime / (4 * math.pi) * ((1 + s * zr) * np.exp(-s * zr) / zr**2 + (1 + s * zv) * np.exp(-s * zv) / zv**2)
    np.testing.assert_allclose(m(0.0), ref, rtol=1e-13)
    assert np.all(np.diff(m(np.linspace(0, 20, 50)), axis=0) < 0)  # monotone decreasing


def test_dipole_hard_cases():
    spec = P.MATERIALS["Spectralon"].dipole()  # sigma_a = 0: sigma_tr = 0, R_d = 1
    np.testing.assert_allclose(spec.total_reflectance(), 1.0)
    big = spec(np.array([0.0, 1e-300, 1e3, 1e200, np.inf]))
    assert np.all(np.isfinite(big)) and np.all(big >= 0)
    sk = P.MATERIALS["Skin1"].dipole()(np.array([1e3, 1e4, 1e300, np.inf]))
    assert np.all(sk[0] < 1e-100) and np.all(sk[1:] == 0.0)  # underflows to 0, not NaN
    black = P.Dipole((0, 0, 0), (1, 1, 1))  # albedo 0
    assert np.all(black(np.linspace(0, 5, 9)) == 0)
    with pytest.raises(ValueError):
        P.Dipole((0, 0, 0), (0, 0, 0))
    with pytest.raises(ValueError):
        P.Dipole((1, 1, 1), (-1, 0, 0))


def test_hankel_transform_of_dipole_matches_quadrature():
    from scipy.special import j0
    m = P.MATERIALS["Skin2"].dipole()
    r = np.geomspace(1e-7, 300, 400001)
    for k in (0.5, 3.0):
        num = 2 * math.pi * np.trapezoid(r[:, None] ** 2 * m(r) * j0(k * r)[:, None], np.log(r), axis=0)
        np.testing.assert_allclose(num, m.hankel(k), rtol=1e-5)


def test_multipole_thick_slab_approaches_dipole():
    mat = P.MATERIALS["Skin1"]
    d = mat.dipole()
    r = np.array([0.0, 0.05, 0.5, 2.0, 8.0])
    for thickness, tol in ((20.0, 2e-2), (200.0, 1e-9)):
        s = P.Multipole(mat.sigma_s_prime, mat.sigma_a, thickness, eta=1.3)
        np.testing.assert_allclose(s(r), d(r), rtol=tol, atol=1e-12)
    s = P.Multipole(mat.sigma_s_prime, mat.sigma_a, 200.0, eta=1.3)
    np.testing.assert_allclose(s.total_reflectance(), d.total_reflectance(), rtol=1e-9)
    assert np.all(s.total_transmittance() < 1e-12)


def test_multipole_slab_reflectance_and_transmittance_integrals():
    s = P.Multipole((10, 10, 10), (0.05, 0.1, 0.2), 1.0, eta=1.3)
    np.testing.assert_allclose(plane_integral(s(R_LOG)), s.total_reflectance(), rtol=1e-4)
    np.testing.assert_allclose(plane_integral(s.transmittance(R_LOG)), s.total_transmittance(), rtol=1e-4)
    tot = s.total_reflectance() + s.total_transmittance()
    assert np.all(tot < 1) and np.all(tot > 0.5)  # energy: some absorbed, none created
    # a thinner slab lets more through
    thin = P.Multipole((10, 10, 10), (0.05, 0.1, 0.2), 0.5, eta=1.3)
    assert np.all(thin.total_transmittance() > s.total_transmittance())
    assert np.all(np.isfinite(s.transmittance(np.array([0, 1, 10]), form="printed")))


def test_layered_stack_consistency():
    sk = P.three_layer_skin()
    r = np.geomspace(1e-5, 150, 1500)
    R = sk(r)
    assert np.all(np.isfinite(R))
    np.testing.assert_allclose(2 * math.pi * np.trapezoid(r[:, None] ** 2 * R, np.log(r), axis=0),
                               sk.total_reflectance(), rtol=1e-3)
    # epidermis over the same material as below: close to the material alone (R_d within 1 %)
    sig = ((10, 10, 10), (0.05, 0.1, 0.2))
    st = P.LayeredMultipole([P.Layer(*sig, 0.5, 1.3), P.Layer(*sig, math.inf, 1.3)])
    np.testing.assert_allclose(st.total_reflectance(), P.Dipole(*sig, 1.3).total_reflectance(), rtol=1e-2)
    # red scatters farthest in the skin example (seed 002 14.4.1)
    mean_r = np.trapezoid(r[:, None] ** 3 * R, np.log(r), axis=0) / np.trapezoid(r[:, None] ** 2 * R, np.log(r), axis=0)
    assert mean_r[0] > mean_r[1] > mean_r[2]
    with pytest.raises(ValueError):
        P.LayeredMultipole([P.Layer(*sig, math.inf), P.Layer(*sig, 1.0)])


@pytest.mark.parametrize("config", P.BURLEY_CONFIGS)
def test_burley_normalized_integrates_to_one(config):
    for A in (0.0, 0.2, 0.8, 1.0):
        b = P.Burley(A, 1.5, config)
        d = b.d
        x = np.geomspace(1e-9, 1e4, 200001)[:, None] * d  # scale with d
        vals = P.burley_normalized(x, d)
        integ = 2 * math.pi * np.trapezoid(x**2 * vals, np.log(x), axis=0)
        np.testing.assert_allclose(integ, 1.0, rtol=1e-6)
        np.testing.assert_allclose(b.total_reflectance(), A)
        assert np.all(np.isfinite(b(np.array([1e-12, 1.0, 1e6]))))


def test_burley_scale_fits():
    np.testing.assert_allclose(P.burley_scale(0.8, "searchlight-mfp"), 1.05)  # eq. 2.86
    np.testing.assert_allclose(P.burley_scale(0.33, "searchlight-dmfp"), 3.5)  # eq. 2.88
    np.testing.assert_allclose(P.burley_scale(0.8, "diffuse-transmission"), 1.1)  # eq. 2.89
    with pytest.raises(ValueError):
        P.Burley(1.2, 1.0)


def test_burley_cdf_is_the_integral_of_the_profile():
    d = 0.7
    r = np.linspace(0, 30, 300001)[1:]
    pdf = 2 * math.pi * r * P.burley_normalized(r, d)
    cum = np.concatenate([[0], np.cumsum(0.5 * (pdf[1:] + pdf[:-1]) * np.diff(r))])
    np.testing.assert_allclose(cum + P.burley_cdf(r[0], d), P.burley_cdf(r, d), atol=2e-6)


def test_burley_cdf_and_analytic_inverse_round_trip():
    u = np.concatenate([np.geomspace(1e-300, 1e-3, 400), np.linspace(1e-3, 1 - 1e-3, 2001),
                        1 - np.geomspace(1e-3, 1e-16, 400)])
    for d in (1.0, 0.05, 3.0):
        r = P.burley_inverse_cdf(u, d)
        assert np.all(np.isfinite(r)) and np.all(r >= 0) and np.all(np.diff(r) <= 0)
        # P(r) = 1 - u to float precision (absolute), and in the tail u itself to relative precision
        np.testing.assert_allclose(P.burley_cdf(r, d), 1 - u, rtol=0, atol=4e-16)
        np.testing.assert_allclose(P.burley_ccdf(r, d), u, rtol=1e-12)  # condition number ~ r/d
        x = np.linspace(0, 60, 3001)[1:] * d
        np.testing.assert_allclose(P.burley_inverse_cdf(P.burley_ccdf(x, d), d), x, rtol=1e-11, atol=1e-15 * d)
    # limits: u -> 1 gives 0, u -> 0 a large finite radius
    assert P.burley_inverse_cdf(1.0) == 0.0
    assert 2000 < P.burley_inverse_cdf(0.0) < 2200
    # the printed eq. 3.12 (G^-1/3 twice) is not an inverse: documented, kept as an option
    assert abs(P.burley_cdf(P.burley_inverse_cdf(0.5, printed=True)) - 0.5) > 0.05


def test_burley_sampling_matches_profile_mean():
    b = P.Burley((0.5, 0.5, 0.5), (1.0, 2.0, 4.0))
    u = (np.arange(200000) + 0.5) / 200000
    samples = b.sample_radius(u)  # (n, 3)
    # mean radius of the pdf 2 pi r R(r)/A = (d + 3 * 3d)/4... = (1/4) d + (3/4) 3d = 2.5 d
    np.testing.assert_allclose(samples.mean(axis=0), 2.5 * b.d, rtol=1e-3)


def test_gaussians_and_deon_table():
    r = np.geomspace(1e-6, 200, 100001)
    for v in (0.0064, 1.0, 7.41):
        np.testing.assert_allclose(2 * math.pi * np.trapezoid(r**2 * P.gaussian(v, r), np.log(r)), 1.0, rtol=1e-6)
    assert len(P.DEON_SKIN_GAUSSIANS) == 6
    w = np.array([g[1] for g in P.DEON_SKIN_GAUSSIANS])
    np.testing.assert_allclose(w.sum(axis=0), [1.0, 1.0, 1.0], atol=0.002)  # d'Eon: ~1 per channel
    np.testing.assert_allclose(P.gaussian(0.0064, 0.0), 1 / (2 * math.pi * 0.0064))
    assert P.deon_skin_profile(np.array([0.0, 1.0])).shape == (2, 3)
    vals = P.sum_of_gaussians(np.array([0.0, 0.5]), [0.1, 1.0], [0.3, 0.7])
    np.testing.assert_allclose(vals, 0.3 * P.gaussian(0.1, np.array([0, 0.5])) + 0.7 * P.gaussian(1.0, np.array([0, 0.5])))
    assert np.all(P.gaussian(1e-3, np.array([1e3, np.inf])) == 0)
    assert P.gaussian(0.0, 1.0) == 0.0


def test_materials_table():
    assert len(P.MATERIALS) == 12
    assert P.material("marble").sigma_s_prime == (2.19, 2.62, 3.00)
    assert all(m.eta == 1.3 for m in P.MATERIALS.values())
    with pytest.raises(KeyError, match="known"):
        P.material("unobtainium")


def _fresnel_dielectric(mu, n1, n2):
    """Unpolarised Fresnel reflectance from medium n1 into n2 at incidence cosine mu (TIR -> 1)."""
    s2 = (n1 / n2) ** 2 * (1 - mu * mu)
    ct = np.sqrt(np.clip(1 - s2, 0, None))
    rs = (n1 * mu - n2 * ct) / (n1 * mu + n2 * ct)
    rp = (n1 * ct - n2 * mu) / (n1 * ct + n2 * mu)
    return np.where(s2 >= 1, 1.0, 0.5 * (rs * rs + rp * rp))


@pytest.mark.parametrize("eta", [0.7, 0.77, 0.9, 1.1, 1.3, 1.4, 1.6])
def test_fresnel_diffuse_reflectance_is_eq_2_49(eta):
    """The rational fits against eq. (2.49) integrated: F_dr = 2 int_0^1 F_r(mu) mu dmu, light inside
    the medium of relative index eta (the fits are good to ~1e-3); A = (1 + F_dr)/(1 - F_dr)."""
    mu = (np.arange(400000) + 0.5) / 400000
    exact = 2 * np.mean(_fresnel_dielectric(mu, eta, 1.0) * mu)
    f = P.fresnel_diffuse_reflectance(eta)
    assert abs(f - exact) < 1.5e-3, (f, exact)
    assert P.boundary_A(eta) == pytest.approx((1 + f) / (1 - f))


def _slab_closed_form(m, k):
    """Independent check of the image positions (eq. 2.60-2.63): the sum over all images is the 1-D
    Dirichlet Green's function on [-z_b0, d + z_bd], z_b = 2 A D, source at l = 1/sigma_t'; R^ and T^
    are its fluxes at z = 0 and z = d (l < d here)."""
    c = m.c
    q = np.sqrt(c.sigma_tr**2 + k * k)
    l, zb0, zbd = 1 / c.sigma_t_prime, 2 * m.A_top * c.D, 2 * m.A_bot * c.D
    Pw = m.thickness + zb0 + zbd
    with np.errstate(divide="ignore", invalid="ignore"):
        R = np.where(q > 0, np.cosh(q * zb0) * np.sinh(q * (m.thickness + zbd - l)) / np.sinh(q * Pw),
                     (m.thickness + zbd - l) / Pw)
        T = np.where(q > 0, np.cosh(q * zbd) * np.sinh(q * (l + zb0)) / np.sinh(q * Pw), (l + zb0) / Pw)
    return c.alpha_prime * R, c.alpha_prime * T


@pytest.mark.parametrize("ssp, sa, d, eta_below", [
    ((10, 10, 10), (0.05, 0.1, 0.2), 1.0, 1.0),
    ((5, 6, 7), (0.5, 0.1, 0.01), 0.5, 1.33),  # different A at the two faces
    ((1, 1, 1), (1e-4, 1e-6, 1e-8), 2.0, 1.0),  # weak absorption: slowly converging image series
    ((1, 1, 1), (0, 0, 0), 2.0, 1.0),  # no absorption: R + T = 1
])
def test_multipole_transforms_match_the_summed_image_series(ssp, sa, d, eta_below):
    m = P.Multipole(ssp, sa, d, eta=1.4, eta_above=1.0, eta_below=eta_below)
    for k in (0.0, 0.3, 2.0, 20.0):
        R, T = _slab_closed_form(m, k)
        np.testing.assert_allclose(m.hankel(k), R, rtol=1e-9, atol=1e-300)
        np.testing.assert_allclose(m.hankel_transmittance(k), T, rtol=1e-9, atol=1e-300)
    if max(sa) == 0:
        np.testing.assert_allclose(m.total_reflectance() + m.total_transmittance(), 1.0, rtol=1e-12)
    assert np.all(np.isfinite(m.hankel(np.array([0.0, 1e-12, 1e-3, 1e3, 1e9]))))


def test_burley_scale_fits_away_from_their_zeros():
    # A = 0.2 exercises the |A - 0.8|^3, (A - 0.33)^4 and (A - 0.8)^2 terms of eq. 2.86, 2.88, 2.89
    np.testing.assert_allclose(P.burley_scale(0.2, "searchlight-mfp"), 1.85 - 0.2 + 7 * 0.6**3)
    np.testing.assert_allclose(P.burley_scale(0.2, "searchlight-dmfp"), 3.5 + 100 * 0.13**4)
    np.testing.assert_allclose(P.burley_scale(0.2, "diffuse-transmission"), 1.9 - 0.2 + 3.5 * 0.6**2)
    np.testing.assert_allclose(P.burley_scale(1.0, "searchlight-mfp"), 0.85 + 7 * 0.2**3)


def test_diffuse_mean_free_path_eq_2_87():
    ssp, sa = np.array([1.0, 2.0, 4.0]), np.array([0.1, 0.2, 0.0])
    st = ssp + sa
    D = (st + sa) / (3 * st**2)
    with np.errstate(divide="ignore"):
        np.testing.assert_allclose(P.diffuse_mean_free_path(ssp, sa), 1 / np.sqrt(sa / D))
    assert np.isinf(P.diffuse_mean_free_path(ssp, sa)[2])


def test_gaussian_never_inf():
    assert np.isfinite(P.gaussian(1e-310, 0.0)) and P.gaussian(1e-310, 1.0) == 0.0
    assert P.gaussian(-1.0, 0.0) == 0.0


def test_burley_is_finite_at_r_zero():
    """The product promise: no Inf, even at the integrable 1/r singularity of eq. 2.83."""
    import numpy as np

    from skinviewer.physics import profiles as P
    v = P.burley_normalized(np.array([0.0, 1e-300, 1e-9]), np.array([[0.5], [1.0], [2.0]]))
    assert np.all(np.isfinite(v)) and np.all(v > 0)


def test_edges_the_mutation_sample_found_unpinned():
    """Issue 36 (notes/mutation.md): eta = 0 is refused like any non-positive index; an unknown material
    names the known ones; a semi-infinite slab transmits nothing, in the same shape as a finite slab's T."""
    import re
    with pytest.raises(ValueError, match="positive"):
        P.fresnel_diffuse_reflectance(0.0)
    with pytest.raises(KeyError, match=re.escape("known: " + ", ".join(P.MATERIALS))):
        P.material("no such skin")
    sig = ((10, 10, 10), (0.05, 0.1, 0.2))
    thick, thin = P.Multipole(*sig, math.inf, eta=1.3), P.Multipole(*sig, 1.0, eta=1.3)
    assert thick.semi_infinite and not thin.semi_infinite
    for r in (1.0, [0.5, 1.0, 2.0]):
        assert thick.transmittance(r).shape == thin.transmittance(r).shape
        assert not thick.transmittance(r).any() and thin.transmittance(r).all()
