"""skinviewer.physics.metrics: the error figures every technique is judged by."""
import numpy as np
import pytest

from skinviewer.physics import metrics as M


def _img(seed=0, shape=(48, 40)):
    rng = np.random.default_rng(seed)
    base = np.linspace(0.05, 0.8, shape[0] * shape[1]).reshape(shape)[..., None] * np.array([1.0, 0.7, 0.5])
    return base + 0.02 * rng.random(shape + (3,))


def test_identical_images_score_zero():
    a = _img()
    e = M.image_error(a, a)
    assert e.rms == (0.0, 0.0, 0.0) and e.p99 == (0.0, 0.0, 0.0) and e.dssim == pytest.approx(0.0, abs=1e-12)


def test_rel_rms_of_a_uniform_scale_is_the_scale():
    a = _img()
    np.testing.assert_allclose(M.rel_rms(1.1 * a, a), [0.1, 0.1, 0.1], rtol=1e-9)
    np.testing.assert_allclose(M.p99_rel(0.9 * a, a), [0.1, 0.1, 0.1], rtol=1e-9)


def test_dssim_is_symmetric_bounded_and_grows_with_noise():
    a = _img()
    rng = np.random.default_rng(3)
    small = a + 0.01 * rng.standard_normal(a.shape)
    large = a + 0.1 * rng.standard_normal(a.shape)
    d_small, d_large = M.dssim(small, a), M.dssim(large, a)
    assert 0.0 < d_small < d_large <= 1.0
    assert M.dssim(a, large) == pytest.approx(d_large, rel=1e-9)


def test_mask_restricts_every_figure():
    a = _img()
    b = a.copy()
    b[:10] *= 3.0  # wrong only outside the mask
    m = np.ones(a.shape[:2], bool)
    m[:16] = False
    e = M.image_error(b, a, m)
    assert max(e.rms) == 0.0 and max(e.p99) == 0.0 and e.dssim < 1e-3
    assert min(M.rel_rms(b, a)) > 0.1


def test_bad_inputs_are_refused():
    a = _img()
    with pytest.raises(ValueError):
        M.rel_rms(a[:-1], a)
    bad = a.copy()
    bad[0, 0, 0] = np.nan
    with pytest.raises(ValueError):
        M.image_error(bad, a)


def test_figure_uncertainty_bounds_every_reference_within_it():
    """A reference moved anywhere within its per-pixel uncertainty u moves RMS and p99 by no more
    than their stated uncertainty (triangle inequality; monotone percentile)."""
    from skinviewer.physics.metrics import image_error
    rng = np.random.default_rng(5)
    ref = rng.uniform(0.2, 1.0, (32, 32, 3))
    x = ref * (1 + 0.05 * rng.normal(size=ref.shape))
    u = 0.01 * ref * rng.uniform(0.5, 1.5, ref.shape)
    e = image_error(x, ref, uncertainty=u)
    assert e.rms_u is not None and min(e.rms_u) > 0 and min(e.p99_u) > 0 and e.dssim_u > 0
    assert "±" in e.summary()
    for _ in range(5):
        moved = ref + u * rng.uniform(-1, 1, ref.shape)
        f = image_error(x, moved)
        assert np.all(np.abs(np.subtract(f.rms, e.rms)) <= np.array(e.rms_u) + 1e-12)
        assert np.all(np.abs(np.subtract(f.p99, e.p99)) <= np.array(e.p99_u) + 0.01 * np.array(e.p99))
