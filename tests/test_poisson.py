"""The 12-tap Poisson disk of the Gosselin blur (seed 000 eq. 13)."""
import numpy as np
import pytest

from skinviewer.physics import poisson


def test_constant_is_the_generator_output():
    gen = poisson.generate_poisson_disk(12, poisson.SEED)
    const = np.array(poisson.POISSON_12)
    assert const.shape == (12, 2)
    # printed at 6 decimals; allow one unit in the last place for cross-platform float rounding
    np.testing.assert_allclose(const, gen, rtol=0, atol=1.5e-6)


def test_deterministic_and_seed_dependent():
    a = poisson.generate_poisson_disk(12, 7)
    b = poisson.generate_poisson_disk(12, 7)
    np.testing.assert_array_equal(a, b)
    c = poisson.generate_poisson_disk(12, 8)
    assert not np.array_equal(a, c)


def test_in_unit_disk_well_spread_and_centred():
    p = np.array(poisson.POISSON_12)
    s = poisson.stats(p)
    assert s["max_radius"] <= 1.0
    assert s["min_distance"] >= poisson.MIN_DISTANCE
    assert s["centroid"] < 1e-6  # the blur does not shift the image
    # no duplicate taps and no tap at the centre (eq. 13 already weights the centre sample)
    assert np.linalg.norm(p, axis=1).min() > 0.3
    # the documented figures are the real ones
    assert abs(s["min_distance"] - 0.657310) < 1e-6


def test_other_sizes_stay_valid():
    p = poisson.generate_poisson_disk(8, 1)
    assert p.shape == (8, 2)
    assert np.linalg.norm(p, axis=1).max() <= 1.0
    assert poisson.stats(p)["min_distance"] > 0.7  # 8 points spread further than 12


def test_radii_give_the_profiles_variance_after_the_iterated_blur():
    """Issue 36 (mutation sample: kernel_axis_moment and radii_mm had no test here). Brute force on both
    sides: ``iterations`` Poisson blurs of radius R (eq. 13: the centre and the 12 taps, weight 1/13 each)
    convolved explicitly -- every sum of one offset per blur -- must have the per-axis variance of the
    sum-of-Gaussians profile, that one measured by quadrature of r^2 over the 2-D profile."""
    from scipy.integrate import quad
    variances = [0.05, 0.4, 2.0]
    weights = [(0.5, 0.2, 0.1), (0.3, 0.5, 0.2), (0.2, 0.3, 0.0)]
    kernel = np.vstack([[0.0, 0.0], np.array(poisson.POISSON_12)])
    for c in range(3):
        def prof(r, p=0, c=c):
            return sum(w[c] * np.exp(-r * r / (2 * v)) / (2 * np.pi * v) * r ** p for v, w in zip(variances, weights))
        mass = quad(lambda r: 2 * np.pi * r * prof(r), 0, 60, limit=200)[0]
        per_axis = quad(lambda r: 2 * np.pi * r * prof(r, 2), 0, 60, limit=200)[0] / mass / 2.0
        for iterations in (1, 2, 3):
            R = poisson.radii_mm(variances, weights, iterations)[c]
            pts = np.zeros((1, 2))
            for _ in range(iterations):  # the k-fold convolution of the 13 equal-weight deltas
                pts = (pts[:, None, :] + R * kernel[None, :, :]).reshape(-1, 2)
            got = 0.5 * (pts[:, 0].var() + pts[:, 1].var())
            assert got == pytest.approx(per_axis, rel=1e-9), (c, iterations)
    assert np.all(poisson.radii_mm(variances, weights, 0) == 0) and poisson.radii_mm(variances, weights, 0).shape == (3,)
    # a given point set's moment: the 13-point kernel's (x^2 + y^2) / 2 averaged, centre included
    pts = np.array([[1.0, 0.0], [0.0, 1.0], [-1.0, 0.0]])
    assert poisson.kernel_axis_moment(pts) == pytest.approx(3.0 / 2.0 / 4.0)
