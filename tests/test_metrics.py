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


def _srgb(c):
    """IEC 61966-2-1 sRGB encoding of linear [0, 1] values (written here, not imported)."""
    c = np.clip(c, 0.0, 1.0)
    return np.where(c <= 0.0031308, 12.92 * c, 1.055 * c ** (1 / 2.4) - 0.055)


def _ssim_at(a, b, i, j):
    """Wang et al. 2004 SSIM at pixel (i, j) of 2-D images, summed directly over an 11 x 11 Gaussian window
    (sigma 1.5, normalised), population moments, C1 = 0.01^2, C2 = 0.03^2 (L = 1)."""
    t = np.arange(-5, 6)
    g = np.exp(-t * t / (2 * 1.5 ** 2))
    w = np.outer(g, g) / np.outer(g, g).sum()
    pa, pb = a[i - 5:i + 6, j - 5:j + 6], b[i - 5:i + 6, j - 5:j + 6]
    ma, mb = (w * pa).sum(), (w * pb).sum()
    va, vb = (w * pa * pa).sum() - ma * ma, (w * pb * pb).sum() - mb * mb
    cov = (w * pa * pb).sum() - ma * mb
    c1, c2 = 0.01 ** 2, 0.03 ** 2
    return (2 * ma * mb + c1) * (2 * cov + c2) / ((ma * ma + mb * mb + c1) * (va + vb + c2))


def test_dssim_value_on_a_known_pair():
    """DSSIM = (1 - SSIM) / 2 (seed 001 eq. 4.3) pinned against an independent SSIM: a closed form for flat
    images, a direct window sum (tests' own code) for a textured pair. Without the /2 the first is 0.9999."""
    white, black = np.ones((16, 16, 3)), np.zeros((16, 16, 3))
    c1 = 1e-4
    assert M.dssim(white, black) == pytest.approx((1 - c1 / (1 + c1)) / 2, abs=1e-12)  # 0.49995
    # flat 0.2 against flat 0.5 (linear): only the luminance term, on the sRGB-encoded values
    a, b = float(_srgb(0.2)), float(_srgb(0.5))
    flat = (1 - (2 * a * b + c1) / (a * a + b * b + c1)) / 2
    assert M.dssim(np.full((16, 16, 3), 0.2), np.full((16, 16, 3), 0.5)) == pytest.approx(flat, abs=1e-12)
    # textured pair: every interior pixel (window inside the image) equals the direct sum
    rng = np.random.default_rng(7)
    x = rng.random((24, 24, 3)) * 0.6
    y = np.clip(x + 0.15 * rng.standard_normal(x.shape), 0, 1)
    ex, ey = _srgb(x), _srgb(y)
    inner = np.zeros((24, 24), bool)
    inner[5:19, 5:19] = True
    want = np.array([[np.mean([(1 - _ssim_at(ex[..., c], ey[..., c], i, j)) / 2 for c in range(3)])
                      for j in range(5, 19)] for i in range(5, 19)])
    np.testing.assert_allclose(M.dssim_map(x, y)[5:19, 5:19], want, atol=1e-12)
    assert M.dssim(x, y, inner) == pytest.approx(want.mean(), abs=1e-12)
    assert 0.05 < want.mean() < 0.5  # a pair far from both ends (the value is not a degenerate 0 or 1/2)
