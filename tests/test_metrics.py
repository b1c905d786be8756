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
    with pytest.raises(ValueError, match=r"image shape \(47, 40, 3\) does not match the reference \(48, 40, 3\)"):
        M.rel_rms(a[:-1], a)
    with pytest.raises(ValueError, match=r"mask shape \(48, 41\) does not match the image \(48, 40\)"):
        M.rel_rms(a, a, np.ones((48, 41), bool))
    bad = a.copy()
    bad[0, 0, 0] = np.nan
    with pytest.raises(ValueError, match="^images must be finite$"):
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


def test_alpha_is_ignored_and_figures_are_exact_on_small_values():
    """RGBA inputs: only RGB counts. A reference of tiny radiance (1e-4) still gives the relative figures
    (no absolute floor on sum ref^2 but 1e-30)."""
    a = _img() * 1e-4
    ra = np.concatenate([a, np.ones(a.shape[:2] + (1,))], -1)
    rb = np.concatenate([1.1 * a, np.zeros(a.shape[:2] + (1,))], -1)  # alpha differs: must not count
    np.testing.assert_allclose(M.rel_rms(rb, ra), [0.1] * 3, rtol=1e-9)
    np.testing.assert_allclose(M.p99_rel(rb, ra), [0.1] * 3, rtol=1e-9)
    assert M.dssim(np.concatenate([a, a[..., :1]], -1), np.concatenate([a, 1 + a[..., :1]], -1)) == 0.0


def test_relative_error_floor_mask_and_percentile():
    """rel_error_map divides by max(ref, 1 % of the channel's mean over the mask) and is 0 outside the
    mask; p99 is numpy's 99th percentile of it over the mask; an empty mask gives zeros."""
    ref = np.ones((12, 100, 3)) * (1.0, 0.5, 0.25)  # channels differ: the floor is per channel
    ref[0, :40] = 0.0  # black pixels (3.6 % of the mask, so p99 is theirs): divided by the floor 0.01 * mean
    ref[11] = 100.0  # outside the mask: must not enter the floor's mean
    x = ref.copy()
    x[0, :40] = 0.002
    rng = np.random.default_rng(2)
    x[1:] *= 1.0 + rng.random((11, 100, 1)) * 0.1
    m = np.ones((12, 100), bool)
    m[11] = False
    x[11] = 50.0  # outside the mask
    e = M.rel_error_map(x, ref, m)
    mean = ref[:11].reshape(-1, 3).mean(0)
    np.testing.assert_allclose(e[0, :40], 0.002 / (0.01 * mean[None, :]) * np.ones((40, 3)))
    np.testing.assert_array_equal(e[11], 0.0)
    np.testing.assert_allclose(e[1:11], np.abs(x[1:11] / ref[1:11] - 1.0))
    np.testing.assert_allclose(M.p99_rel(x, ref, m), 0.002 / (0.01 * mean))  # the black pixels' error
    empty = np.zeros((12, 100), bool)
    np.testing.assert_array_equal(M.p99_rel(x, ref, empty), np.zeros(3))
    assert M.p99_rel(x, ref, empty).shape == (3,)
    np.testing.assert_array_equal(M.rel_error_map(x, ref, empty), np.zeros((12, 100, 3)))
    assert M.dssim(x, ref, empty) == 0.0


def test_display_encoding_exposure_and_clamp():
    v = np.array([[[0.0, 0.5, 2.0], [-1.0, 0.1, 0.25]]])
    want = _srgb(np.clip(v * 2.0, 0, 1))
    np.testing.assert_allclose(M.display_encode(v, exposure=2.0), want, atol=1e-15)
    assert M.display_encode(np.full((1, 1, 4), 0.5))[0, 0].shape == (3,)
    # the exposure reaches DSSIM and image_error: exposure 2 is the same as doubling both images
    a, b = _img(1) * 0.4, _img(2) * 0.4
    assert M.dssim(a, b, exposure=2.0) == pytest.approx(M.dssim(2 * a, 2 * b), abs=1e-15)
    assert M.dssim(a, b, exposure=2.0) != pytest.approx(M.dssim(a, b), abs=1e-6)
    np.testing.assert_allclose(M.dssim_map(a, b, exposure=2.0), M.dssim_map(2 * a, 2 * b), atol=1e-15)
    e = M.image_error(a, b, exposure=2.0)
    assert e.dssim == M.dssim(a, b, exposure=2.0) and M.image_error(a, b).dssim == M.dssim(a, b)


def test_image_error_summary_and_json():
    e = M.ImageError((0.01, 0.02, 0.5), (0.1, 0.2, 0.3), 0.01234)
    assert e.summary() == "RMS 1.00 / 2.00 / 50.00 %  p99 10.00 / 20.00 / 30.00 %  DSSIM 0.0123"
    assert e.rms_mean == pytest.approx(0.53 / 3)
    j = e.to_json()
    assert j["rms"] == (0.01, 0.02, 0.5) and j["dssim"] == 0.01234 and j["dssim_setup"] == M.DSSIM_SETUP


def test_integer_images_are_compared_as_numbers():
    """8-bit images (a PNG read back) give the figures of the same values as floats (no uint8 wrap-around)."""
    rng = np.random.default_rng(4)
    a = rng.integers(0, 256, (16, 16, 3)).astype(np.uint8)
    b = rng.integers(0, 256, (16, 16, 3)).astype(np.uint8)
    np.testing.assert_allclose(M.rel_rms(a, b), M.rel_rms(a.astype(float), b.astype(float)), rtol=1e-12)
    np.testing.assert_allclose(M.p99_rel(a, b), M.p99_rel(a.astype(float), b.astype(float)), rtol=1e-12)


def test_the_pairwise_order_holds_for_every_truth_within_the_uncertainty_and_only_then():
    """metrics.certainly_better is exact: where it says a is more accurate than b, a's relative RMS is
    below b's for random truths and for the worst truth within u; where it does not, the worst truth
    (d = -u sign(a - b)) reverses or ties the order. Errors a and b share cancel: 3 % vs 5 % too bright
    with a +-2 % truth is ordered pairwise, while the figures' own bounds (0.03 +- 0.02 vs 0.05 +- 0.02)
    overlap (a tie by `tied`)."""
    rng = np.random.default_rng(3)
    ref = rng.uniform(0.2, 1.0, (24, 24, 3))
    u = 0.02 * ref
    a, b = ref * 1.03, ref * 1.05
    assert M.certainly_better(a, b, ref, u).all() and not M.certainly_better(b, a, ref, u).any()
    ua, ub = M.figure_uncertainty(a, ref, u)[0], M.figure_uncertainty(b, ref, u)[0]
    assert M.tied(float(M.rel_rms(a, ref).mean()), float(ua.mean()), float(M.rel_rms(b, ref).mean()), float(ub.mean()))
    for _ in range(50):  # any truth within u keeps the order
        t = ref + rng.uniform(-1, 1, ref.shape) * u
        assert (M.rel_rms(a, t) < M.rel_rms(b, t)).all()
    # noisy images whose order depends on the truth in some channels: the test says so exactly
    for k in range(30):
        a = ref * (1 + rng.normal(0, 0.03, ref.shape))
        b = ref * (1 + rng.normal(0, 0.03 + 0.002 * k, ref.shape))
        got = M.certainly_better(a, b, ref, u)
        worst = ref - u * np.sign(a - b)  # the truth that favours b most
        assert np.array_equal(got, M.rel_rms(a, worst) < M.rel_rms(b, worst))


def test_the_paired_p99_bounds_hold_for_every_truth_within_the_uncertainty_and_are_exact_without_one():
    """p99_change_bounds (issue 30 item 4): p99(a) - p99(b) against one truth r + d, |d| <= u, lies
    within the bounds for sampled and extreme truths; with u = 0 both bounds are the plain difference;
    a shared tail whose truth is uncertain leaves the per-figure bounds tied while the paired bounds
    decide; and a difference the uncertainty can reverse is reported as a tie."""
    rng = np.random.default_rng(7)
    for _ in range(60):
        n = int(rng.integers(40, 300))
        ref = rng.uniform(0.05, 1.0, (n, 1, 3))
        a = ref * (1 + rng.normal(0, 0.3, ref.shape))
        b = a.copy()
        ch = rng.random(n) < rng.uniform(0.0, 0.5)
        b[ch] = ref[ch] * (1 + rng.normal(0, 0.3, (int(ch.sum()), 1, 3)))
        u = ref * rng.uniform(0, 0.1, ref.shape) * (rng.random(ref.shape) < 0.5)
        lo, hi = M.p99_change_bounds(a, b, ref, u, same=0.0)
        den = np.maximum(ref, 0.01 * ref.mean((0, 1)))
        for _ in range(30):
            r2 = ref + u * rng.choice([-1.0, 0.0, 1.0, float(rng.uniform(-1, 1))], size=ref.shape)
            diff = (np.percentile((np.abs(a - r2) / den).reshape(-1, 3), 99, 0)
                    - np.percentile((np.abs(b - r2) / den).reshape(-1, 3), 99, 0))
            assert np.all(diff <= hi + 1e-12) and np.all(diff >= lo - 1e-12)
        lo0, hi0 = M.p99_change_bounds(a, b, ref, 0 * u, same=0.0)
        exact = M.p99_rel(a, ref) - M.p99_rel(b, ref)
        np.testing.assert_allclose(lo0, exact, atol=1e-12)
        np.testing.assert_allclose(hi0, exact, atol=1e-12)
    # a shared tail (the top 3 % identical in a and b, its truth uncertain by 20 %) and b 1 % worse
    # everywhere below it: the figures' own bounds leave a +-20-point tie, the paired bounds hold the
    # difference to within ``same`` (what the images share cancels)
    ref = np.ones((50, 40, 3))
    err = np.linspace(0.0, 0.1, ref.size // 3).reshape(50, 40)[..., None] * np.ones(3)
    tail = err >= np.quantile(err, 0.97)
    err = np.where(tail, 0.6, err)
    a = ref * (1 + err)
    b = ref * (1 + np.where(tail, err, err + 0.01))
    b[tail] = a[tail]
    u = np.where(tail, 0.2, 0.0) * ref
    ea, eb = M.image_error(a, ref, uncertainty=u), M.image_error(b, ref, uncertainty=u)
    assert all(M.tied(x, ux, y, uy) for x, ux, y, uy in zip(ea.p99, ea.p99_u, eb.p99, eb.p99_u))
    lo, hi = M.p99_change_bounds(a, b, ref, u)
    assert np.all(hi <= 1e-3 + 1e-12) and np.all(lo >= -1e-3 - 1e-12)
    assert all(pu > 0.15 for pu in ea.p99_u)
    # the same pair where the tail differs by less than its truth's uncertainty: a tie, never ranked
    b2 = b.copy()
    b2[tail] = ref[tail] * 1.59
    assert M.p99_change(a, b2, ref, u) == ("tie", "tie", "tie")
    assert M.p99_change(a, b2, ref, 0 * u) == ("higher", "higher", "higher")


def test_a_p99_order_the_uncertainty_can_reverse_has_a_witness_and_a_decided_one_has_none():
    """p99_change_witness (issue 30 item 4): the differences it finds under truths within u lie within
    p99_change_bounds (both judge a and b against the same truth); a tail 1 % apart on either side of
    the truth, uncertain by 20 %, is reversed by the truth d = +u: a witness, so that tie is real; the same
    tail with both above the truth keeps its order under every truth tried while the bounds (a
    relaxation) call it a tie: undecided, not reversed; where the bounds decide, no truth reverses it."""
    rng = np.random.default_rng(11)
    ref = rng.uniform(0.2, 1.0, (60, 50, 3))
    err = rng.uniform(0.0, 0.1, ref.shape)
    tail = err >= np.quantile(err, 0.98, axis=(0, 1))
    u = np.where(tail, 0.2, 0.001) * ref
    a = ref * (1 + np.where(tail, 0.5, err))
    for b_tail, verdict, witness in ((-0.49, "tie", True), (0.51, "tie", False), (1.0, "lower", False)):
        b = ref * (1 + np.where(tail, b_tail, err))
        lo, hi = M.p99_change_bounds(a, b, ref, u)
        found_lo, found_hi, share = M.p99_change_witness(a, b, ref, u)
        assert np.all(found_lo >= lo - 1e-12) and np.all(found_hi <= hi + 1e-12)
        assert M.p99_change(a, b, ref, u) == (verdict,) * 3
        c0 = M.p99_rel(a, ref) - M.p99_rel(b, ref)
        reversed_ = (found_lo < 0) & (found_hi > 0)
        assert np.all(reversed_ == witness) and np.all((share < 1) == witness), (b_tail, c0, found_lo, found_hi)
