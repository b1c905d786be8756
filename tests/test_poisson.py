"""The 12-tap Poisson disk of the Gosselin blur (seed 000 eq. 13)."""
import numpy as np

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
