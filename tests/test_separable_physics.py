"""numpy references of the screen-space techniques (spec §12.2, §12.3, §12.5): Jimenez 2009 stretch
factors and taps, the Jimenez 2015 kernel against the [SEP] presets, Jimenez 2010 transmittance."""
from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.signal import fftconvolve

from skinviewer.ground.settings import Settings
from skinviewer.physics.separable import (
    focal_px,
    follow_surface,
    gaussian_taps,
    incremental_sigmas,
    kernel_offsets,
    limit_gaussians,
    preintegrated_gaussians,
    rotated_taps,
    separable_kernel,
    stretch_px_per_mm,
    tap_offset_px,
)
from skinviewer.physics.transmittance import backlit, profile_distance, transmittance

DEON = [(g.variance, g.weights) for g in Settings().deon.gaussians]

# iryoku/separable-sss SeparableSSS.h preset kernels (reference data: weights RGB, offset), the
# centre first, then the negative half (the positive half mirrors it)
SEP_PRESETS = {
    11: [(0.560479, 0.669086, 0.784728, 0), (0.00471691, 0.000184771, 5.07566e-005, -2),
         (0.0192831, 0.00282018, 0.00084214, -1.28), (0.03639, 0.0130999, 0.00643685, -0.72),
         (0.0821904, 0.0358608, 0.0209261, -0.32), (0.0771802, 0.113491, 0.0793803, -0.08)],
    17: [(0.536343, 0.624624, 0.748867, 0), (0.00317394, 0.000134823, 3.77269e-005, -2),
         (0.0100386, 0.000914679, 0.000275702, -1.53125), (0.0144609, 0.00317269, 0.00106399, -1.125),
         (0.0216301, 0.00794618, 0.00376991, -0.78125), (0.0347317, 0.0151085, 0.00871983, -0.5),
         (0.0571056, 0.0287432, 0.0172844, -0.28125), (0.0582416, 0.0659959, 0.0411329, -0.125),
         (0.0324462, 0.0656718, 0.0532821, -0.03125)],
    25: [(0.530605, 0.613514, 0.739601, 0), (0.000973794, 1.11862e-005, 9.43437e-007, -3),
         (0.00333804, 7.85443e-005, 1.2945e-005, -2.52083), (0.00500364, 0.00020094, 5.28848e-005, -2.08333),
         (0.00700976, 0.00049366, 0.000151938, -1.6875), (0.0094389, 0.00139119, 0.000416598, -1.33333),
         (0.0128496, 0.00356329, 0.00132016, -1.02083), (0.017924, 0.00711691, 0.00347194, -0.75),
         (0.0263642, 0.0119715, 0.00684598, -0.520833), (0.0410172, 0.0199899, 0.0118481, -0.333333),
         (0.0493588, 0.0367726, 0.0219485, -0.1875), (0.0402784, 0.0657244, 0.04631, -0.0833333),
         (0.0211412, 0.0459286, 0.0378196, -0.0208333)],
}


# -- Jimenez 2009 --------------------------------------------------------------------------------

def test_t2_1_fronto_parallel_footprint_inverse_depth():
    f = focal_px(30.0, 128)
    s1 = stretch_px_per_mm(100.0, 0.0, 11.0, 800.0, f)
    s2 = stretch_px_per_mm(200.0, 0.0, 11.0, 800.0, f)
    assert abs(s1 - f / 100.0) < 1e-9  # alpha = 11, no gradient: the true projection
    assert abs(s1 / s2 - 2.0) < 1e-12
    assert abs(stretch_px_per_mm(100.0, 0.0, 22.0, 800.0, f) / s1 - 2.0) < 1e-12  # alpha scales it


def test_t2_2_tilted_plane_shrinks_monotonically():
    f = focal_px(30.0, 128)
    z = 100.0
    tilts = np.radians([0, 15, 30, 45, 60, 75])
    g = np.tan(tilts) * z / f  # mm of depth per pixel along x for a plane tilted about y
    sx = stretch_px_per_mm(z, g, 11.0, 800.0, f)
    assert np.all(np.diff(sx) < 0)
    np.testing.assert_allclose(sx, (f / (z + 800.0 * g)))
    assert stretch_px_per_mm(z, 0.0, 11.0, 800.0, f) == sx[0]  # s_y: no gradient along y


def test_gaussian_taps_unit_variance_and_seven_taps_are_deons():
    from skinviewer.physics.diffusion import KERNEL7
    for n in (3, 7, 11, 17, 25, 63):
        x, w = gaussian_taps(n)
        assert abs(w.sum() - 1) < 1e-12 and abs(np.sum(w * x * x) - 1) < 1e-9
        assert np.allclose(x, -x[::-1]) and np.allclose(w, w[::-1])
    np.testing.assert_allclose(gaussian_taps(7)[1], KERNEL7, atol=1e-12)
    with pytest.raises(ValueError):
        gaussian_taps(8)


def test_bilinear_compensation_gives_the_exact_variance():
    from skinviewer.physics.separable import (
        bilinear_compensated_step,
        bilinear_variance,
    )
    for n in (7, 17, 25):
        x, w = gaussian_taps(n)
        for sigma in (1.3, 2.7, 6.1, 17.0):
            step = bilinear_compensated_step(sigma, x, w)
            total = step * step + bilinear_variance(step, x, w)
            assert abs(total - sigma * sigma) < 0.02 * sigma * sigma, (n, sigma, total)
            assert step <= sigma
    assert bilinear_variance(2.0, [1.0, 2.0], [0.5, 0.5]) == 0.0  # integer offsets: no added variance


def test_incremental_sigmas_add_up_and_gaussian_limit_keeps_energy():
    vs = [g[0] for g in DEON]
    sig = incremental_sigmas(vs)
    assert abs(sum(s * s for s in sig) - vs[-1]) < 1e-12
    assert incremental_sigmas([1.0, 0.5, 2.0]) == [1.0, 0.0, 1.0]
    for k in range(1, 7):
        kept = limit_gaussians(DEON, k)
        assert len(kept) == k
        np.testing.assert_allclose(sum(w for _, w in kept), sum(np.asarray(w) for _, w in DEON))


# -- Jimenez 2015 --------------------------------------------------------------------------------

@pytest.mark.parametrize("n", [11, 17, 25])
def test_t3_1_kernel_equals_sep_presets(n):
    k, x = separable_kernel(n)
    ref = np.array(SEP_PRESETS[n])
    half = len(ref)
    np.testing.assert_allclose(x[:half], ref[:, 3], atol=1e-5)
    np.testing.assert_allclose(k[:half], ref[:, :3], atol=1e-5, rtol=1e-5)
    np.testing.assert_allclose(x[half:], -ref[1:, 3][::-1], atol=1e-5)  # mirrored positive half
    np.testing.assert_allclose(k[half:], ref[1:, :3][::-1], atol=1e-5, rtol=1e-5)


@pytest.mark.parametrize("n", [3, 11, 17, 25, 33, 63])
def test_t3_2_kernel_sums_to_one(n):
    for strength, falloff in (((0.48, 0.41, 0.28), (1.0, 0.37, 0.3)), ((1, 1, 1), (0.2, 2.0, 5.0)),
                              ((0, 0, 0), (1, 1, 1))):
        k, x = separable_kernel(n, strength, falloff)
        np.testing.assert_allclose(k.sum(axis=0), 1.0, atol=1e-6)
        assert np.all(k >= 0) and np.all(np.isfinite(k))
    k, _ = separable_kernel(n, (0, 0, 0))
    assert np.all(k[0] == 1) and np.all(k[1:] == 0)  # strength 0: identity
    assert abs(kernel_offsets(n).max() - (3 if n > 20 else 2)) < 1e-12


def test_t3_4_tap_offsets_scale_with_depth():
    f = focal_px(20.0, 1080)
    x = np.array([0.5, 1.0, 2.0])
    off = tap_offset_px(x, 3.0, 500.0, f)
    np.testing.assert_allclose(off, x * f / 500.0)  # width 3 mm: profile mm at their true size
    np.testing.assert_allclose(tap_offset_px(x, 3.0, 1000.0, f), off / 2)
    # in [SEP]'s UV units (v in [0, 1]): x width / (3 z 2 tan(fovy / 2)) (its factor 2 is in sssWidth)
    np.testing.assert_allclose(off / 1080, x * 3.0 / (3 * 500.0 * 2 * math.tan(math.radians(10.0))))


def test_t3_5_follow_surface():
    tap, centre = np.array([[1.0, 2.0, 3.0]]), np.array([[5.0, 5.0, 5.0]])
    np.testing.assert_array_equal(follow_surface(tap, centre, 0.0, 4.0), tap)
    np.testing.assert_array_equal(follow_surface(tap, centre, 4.0, 4.0), centre)
    np.testing.assert_array_equal(follow_surface(tap, centre, -40.0, 4.0), centre)
    np.testing.assert_allclose(follow_surface(tap, centre, 1.0, 4.0), 0.75 * tap + 0.25 * centre)


def test_t3_6_preintegration_exact_for_additively_separable_input():
    # eq. 3.5-3.6: E(x, y) = E1(x) + E2(y) convolved with the radial 2-D sum of Gaussians equals the
    # 1-D convolution with the pre-integrated profile a_p
    h = 0.05
    x = np.arange(-12, 12 + h / 2, h)
    rng = np.random.default_rng(1)
    E1 = np.convolve(rng.random(x.size), np.ones(9) / 9, "same")
    E2 = np.sin(x * 1.3) + 1.5
    E = E1[None, :] + E2[:, None]
    X, Y = np.meshgrid(x, x)
    r = np.hypot(X, Y)
    from skinviewer.physics.diffusion import profile
    K2 = profile(r, [(v, w) for v, w in DEON[1:]])[..., 0] * h * h  # red, without the sub-grid term
    ref = fftconvolve(E, K2, mode="same")
    ap = preintegrated_gaussians(x, [(v, w) for v, w in DEON[1:]])[..., 0] * h
    sep = np.convolve(E1, ap, "same")[None, :] + np.convolve(E2, ap, "same")[:, None]
    c = slice(x.size // 2 - 40, x.size // 2 + 40)  # away from the borders
    np.testing.assert_allclose(sep[c, c], ref[c, c], rtol=1e-3)


def test_rotated_taps_only_inner():
    x = kernel_offsets(17)
    p = rotated_taps(x, 0.1, math.pi / 2)
    inner = np.abs(x) <= 0.2 + 1e-12
    assert inner.sum() == 5  # the centre and +-0.03125, +-0.125 mm
    np.testing.assert_allclose(np.hypot(p[:, 0], p[:, 1]), np.abs(x))  # same distances
    assert np.all(p[~inner, 1] == 0) and np.allclose(p[inner, 0], 0, atol=1e-12) and np.any(p[inner, 1] != 0)


# -- Jimenez 2010 transmittance ------------------------------------------------------------------

def test_t5_1_transmittance_vectors_and_monotonic():
    # spec §6.2 step 4 vectors as printed: each must match to half a unit of its last digit
    ref = {0.1: ("0.787", "0.567", "0.423"), 0.25: ("0.637", "0.244", "0.101"), 0.5: ("0.495", "0.062", "0.006"),
           1.0: ("0.305", "0.0046", "0.0012"), 2.0: ("0.094", "5.4e-4", "1e-5")}
    np.testing.assert_allclose(transmittance(0.0, DEON), 1.0, atol=1e-3)  # the columns sum to 1
    for d, t in ref.items():
        got = transmittance(d, DEON)
        for g, txt in zip(got, t):
            mant, _, exp = txt.partition("e")
            decimals = len(mant.split(".")[1]) if "." in mant else 0
            ulp = 10.0 ** (-decimals + (int(exp) if exp else 0))
            assert abs(g - float(txt)) <= 0.5 * ulp + 1e-12, (d, g, txt)
    d = np.linspace(0, 10, 2001)
    for form in ("printed", "exact"):
        T = transmittance(d, DEON, form)
        assert np.all(np.diff(T, axis=0) <= 1e-15)
        assert np.all(T[1:, 0] >= T[1:, 1]) and np.all(T[1:, 1] >= T[1:, 2] - 1e-15)
    # exact = printed at d / sqrt(2)
    np.testing.assert_allclose(transmittance(d, DEON, "exact"), transmittance(d / math.sqrt(2), DEON))


def test_t5_2_backlit_wrap_and_distance_scale():
    T = backlit(0.5, DEON, np.array([-0.3, -0.31, 0.0, 0.7, 1.0]))
    assert np.all(T[0] == 0) and np.all(T[1] == 0)  # zero when L.(-N) <= -0.3
    assert np.all(T[3] == T[4])  # saturated
    assert abs(profile_distance(10.0, 0.83) - 8.25 * 0.17 / 3.0 * 10.0) < 1e-12
    assert profile_distance(10.0, 0.999) < profile_distance(10.0, 0.5)


def test_edges_the_mutation_sample_found_unpinned():
    """Issue 36 (notes/mutation.md): eq. 3.2 below 1 mm of depth; the bilinear-compensated step solves
    step^2 + bilinear variance(step) = sigma^2 also for sub-pixel sigmas; a zero-variance Gaussian of
    eq. 3.18 is a delta (transmits only at d = 0); backlit's default form."""
    from skinviewer.physics import separable as SP
    from skinviewer.physics.transmittance import transmittance as T
    assert SP.stretch_px_per_mm(0.5, 0.0, 11.0, 0.0, 100.0) == pytest.approx(200.0)  # focal / d, d < 1 mm
    x, w = SP.gaussian_taps(7)
    for sigma in (0.9, 1.5, 3.0):
        step = SP.bilinear_compensated_step(sigma, x, w)
        # two fixed-point steps: measured residual 0.56 % of sigma^2 at most; a step of 1 px at sigma 0.9 is 23 % off
        assert abs(step * step + SP.bilinear_variance(step, x, w) - sigma * sigma) < 0.01 * sigma * sigma
    np.testing.assert_array_equal(T([0.0, 1.0], [(0.0, (0.2, 0.3, 0.5))]), [[0.2, 0.3, 0.5], [0.0, 0.0, 0.0]])
    # backlit() defaults to the printed form (eq. 3.18 as [SEP] ships it): e^(-d^2 / v), wrap 0.3
    from skinviewer.physics.transmittance import backlit
    np.testing.assert_allclose(backlit([1.0], [(2.0, (1.0, 1.0, 1.0))], [0.2]), [[0.5 * math.exp(-0.5)] * 3])


def _fetched_variance(step_px, offsets, weights):
    """Brute force: the discrete kernel a bilinear fetch really applies -- each tap at x step px splits its
    weight onto the two pixels around it, (1 - f, f) -- and that kernel's variance about 0 (px^2)."""
    acc = {}
    for x, w in zip(np.asarray(offsets, np.float64) * step_px, weights):
        i = math.floor(x)
        f = x - i
        acc[i] = acc.get(i, 0.0) + w * (1.0 - f)
        acc[i + 1] = acc.get(i + 1, 0.0) + w * f
    return sum(w * i * i for i, w in acc.items())


def test_second_mutation_round_separable_pins():
    """Issue 36, the second sample of separable.py: the compensated step is the GLSL's *two* fixed-point
    steps (ss_gauss_blur.frag: `it < 2`) of step^2 = sigma^2 - (bilinear variance), the bilinear variance
    taken from the kernel a fetch really applies; [SEP]'s profile integrates to sum(w) f^2 pi / 3.14 (its
    3.14 for pi, eq. in spec §4.2 step 4); a bad tap count names the rule; float32 inputs give the float64
    answer (offsets read back from GL buffers are float32)."""
    from scipy.integrate import quad

    from skinviewer.physics import separable as SP
    x, w = gaussian_taps(7)
    assert sum(wi * xi * xi for xi, wi in zip(x, w)) == pytest.approx(1.0, abs=1e-12)  # unit variance taps
    sigma = 0.8  # sub-pixel: two and three fixed-point steps differ by 4e-4 px here
    s = sigma
    for _ in range(2):
        s = math.sqrt(max(sigma * sigma - (_fetched_variance(s, x, w) - s * s), 0.0))
    assert SP.bilinear_compensated_step(sigma, x, w) == pytest.approx(s, rel=1e-12)
    assert SP.bilinear_variance(s, x, w) == pytest.approx(_fetched_variance(s, x, w) - s * s, abs=1e-12)
    # the profile's integral over the plane, by quadrature of 2 pi r P(r): each term integrates to w f^2 (pi / 3.14)
    falloff = (1.0, 0.37, 0.30)
    for c in range(3):
        f = 0.001 + falloff[c]
        got = quad(lambda r, c=c: 2.0 * math.pi * r * SP.sep_profile(r, falloff)[c], 0.0, 40.0, limit=200)[0]
        assert got == pytest.approx(sum(wk for wk, _ in SP.SEP_PROFILE) * f * f * math.pi / 3.14, rel=1e-8)
    with pytest.raises(ValueError, match="odd and >= 3"):
        kernel_offsets(4)
    # float32 inputs: computed in float64 (a float32 product is 1e-7 off)
    x32 = np.float32([0.1, 0.7, 1.3])
    w32 = np.float32([0.2, 0.5, 0.3])
    xd, wd = x32.astype(np.float64), w32.astype(np.float64)
    fd = np.mod(xd * 3.0, 1.0)
    assert SP.bilinear_variance(3.0, x32, w32) == pytest.approx(float(np.sum(wd * fd * (1.0 - fd))), rel=1e-12, abs=0)
    want = sum(float(w32[0]) * math.exp(-float(v) ** 2 / (2.0 * 0.3)) / math.sqrt(2.0 * math.pi * 0.3) for v in x32)
    got = preintegrated_gaussians(x32, [(0.3, (float(w32[0]),) * 3)])
    np.testing.assert_allclose(got.sum(axis=0), [want] * 3, rtol=1e-13, atol=0)
    t = rotated_taps(np.float32([-0.3, 0.1, 0.3]), 0.5, 0.7)
    np.testing.assert_allclose(t[1], [math.cos(0.7) * float(np.float32(0.1)), math.sin(0.7) * float(np.float32(0.1))],
                               rtol=1e-14, atol=0)
    # eq. 3.2 from a float32 depth buffer and its float32 derivative: the float64 stretch of the same values
    d32, g32 = np.float32([0.7, 313.3]), np.float32([0.013, 1.7])
    want = [(8.0 / 11.0) * 1234.5 / (float(d) + 0.37 * float(g)) for d, g in zip(d32, g32)]
    np.testing.assert_allclose(stretch_px_per_mm(d32, g32, 8.0, 0.37, 1234.5), want, rtol=1e-14, atol=0)
    # strength clamped to [0, 1]: a negative strength is 0 (the centre tap only), above 1 is 1
    k0, _ = separable_kernel(11, strength=(-0.5, 0.0, 1.7))
    np.testing.assert_array_equal(k0[:, 0], np.eye(11)[0])
    np.testing.assert_array_equal(k0[:, 0], k0[:, 1])
    np.testing.assert_allclose(k0[:, 2], separable_kernel(11, strength=(1.0, 1.0, 1.0))[0][:, 2], rtol=1e-15)
