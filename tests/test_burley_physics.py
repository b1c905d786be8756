"""Burley sampling math (skinviewer/physics/burley.py): spec §12.1 T1.1-T1.2, §12.4, §12.6 and §13 on the
numpy reference. The GLSL is checked against this reference in test_burley_gpu.py."""
from __future__ import annotations

import itertools
import math

import numpy as np
import pytest

from skinviewer.physics import burley as B


def test_cdf_values_t11():
    np.testing.assert_allclose(B.cdf([0.5, 1.0, 3.0, 10.0]), [0.213506, 0.370632, 0.711644, 0.973233], atol=1e-6)


def test_inverse_cdf_values_and_round_trip_in_float32_t12():
    np.testing.assert_allclose(B.inverse_cdf([0.1, 0.5, 0.9, 0.997]), [0.214462, 1.552183, 6.062229, 16.564399],
                               atol=1e-6)
    assert B.FILTER_RADIUS_UNIT == pytest.approx(16.564399, abs=1e-6)
    p = np.linspace(0.001, 0.999, 4001).astype(np.float32)
    # the GLSL formula evaluated in float32 (shaders/lib/burley.glsl burley_x_of_u)
    u = (np.float32(1) - p).astype(np.float32)
    G = np.float32(1) + np.float32(4) * u * (np.float32(2) * u + np.sqrt(np.float32(1) + np.float32(4) * u * u))
    g = np.power(G, np.float32(1.0 / 3.0))
    x = np.float32(3) * np.log((np.float32(1) + np.float32(1) / g + g) / (np.float32(4) * u))
    assert x.dtype == np.float32
    assert np.max(np.abs(B.cdf(x.astype(np.float64)) - p)) < 1e-5


def test_printed_inverse_eq_3_12_is_not_an_inverse():
    # seed 001 prints G^(-1/3) twice in eq. 3.12 (spec E7): at p = 0.5 it returns 0.1625 d, P of that is 0.077
    printed = B.inverse_cdf(0.5, printed=True)
    assert printed == pytest.approx(0.1625, abs=1e-4)
    assert abs(B.cdf(printed) - 0.5) > 0.4
    correct = B.inverse_cdf(0.5)
    assert abs(B.cdf(correct) - 0.5) < 1e-9


def test_stratified_radii_match_spec_13():
    np.testing.assert_allclose(B.sample_set(12).x, [0.0857, 0.2731, 0.4858, 0.7305, 1.0162, 1.3561, 1.7700, 2.2893,
                                                    2.9685, 3.9154, 5.4024, 8.6742], atol=1e-4)
    np.testing.assert_allclose(B.sample_set(10).x, [0.1035, 0.3340, 0.6037, 0.9255, 1.3192, 1.8165, 2.4728,
                                                    3.3979, 4.8670, 8.1286], atol=1e-4)
    np.testing.assert_allclose(B.sample_set(22).x[-2:], [7.2019, 10.4904], atol=1e-4)
    assert B.sample_set(21).x[-1] == pytest.approx(10.351, abs=1e-3)
    assert B.sample_set(55).x[-1] == pytest.approx(13.2385, abs=1e-4)


def test_golden_angle_directions_and_rcp_pdf():
    s = B.sample_set(22)
    assert B.GOLDEN_ANGLE == pytest.approx(2.399963229728653, abs=1e-12)
    steps = np.mod(np.diff(s.phi), 2 * math.pi)
    np.testing.assert_allclose(np.minimum(steps, 2 * math.pi - steps), B.GOLDEN_ANGLE, atol=1e-12)
    # rcpPdf = 1/p(r, phi) with p the polar pdf: p integrates to 1 over r/d in [0, inf) and phi in [0, 2 pi)
    x = np.linspace(0, 200, 400001)
    assert 2 * math.pi * np.trapezoid(B.polar_pdf_unit(x), x) == pytest.approx(1.0, abs=1e-6)
    np.testing.assert_allclose(s.rcp_pdf * B.polar_pdf_unit(s.x), 1.0)


def test_ring_split_t67():
    for n, inner in ((12, 10), (10, 8), (22, 19), (30, 27)):
        f = B.sample_set(n).inner
        assert f.sum() == inner and np.all(f[:inner])  # the first samples by radius
    assert B.ring_flags(B.sample_set(22).x, "area-third").sum() == 20  # the other reading of 1:3
    assert B.ring_flags(B.sample_set(12).x, "equal-count").sum() == 6
    with pytest.raises(ValueError):
        B.ring_flags(np.ones(3), "nope")


def test_transmission_t48():
    np.testing.assert_allclose(B.transmittance([0.5, 1, 2, 4], 1.0), [0.786494, 0.629368, 0.418897, 0.202277],
                               atol=1e-6)
    for t in (0.5, 1.0, 2.0, 4.0):
        assert B.transmittance(t, 1.0) == pytest.approx(B.transmittance_numeric(t, 1.0), abs=1e-5)
    assert B.transmittance(0.0, [1.0, 2.0, 3.0], 0.7) == pytest.approx(0.7)
    # thick mode: attenuated by e^(-S dt / 3) beyond the baked thickness, never amplified
    S = np.array([0.5, 1.0, 2.0])
    np.testing.assert_allclose(B.transmittance_thick(1.0, 3.0, S), B.transmittance(1.0, S) * np.exp(-S * 2 / 3))
    np.testing.assert_allclose(B.transmittance_thick(1.0, 0.5, S), B.transmittance(1.0, S))


def test_shape_from_albedo_and_mfp():
    d = B.shape_distance([0.1, 0.5, 0.9], 1.0, "diffuse-transmission")  # eq. 2.89 test vectors, spec §1.4
    np.testing.assert_allclose(1 / d, [3.515, 1.715, 1.035], atol=1e-3)
    np.testing.assert_allclose(B.shape_distance([0.3, 0.3, 0.3], [1, 2, 3], "direct"), [1, 2, 3])
    p = B.profile([0.5, 0.5, 0.5], [1.0, 2.0, 4.0], "direct")
    assert p.d == 4.0 and p.filter_radius == pytest.approx(4 * 16.5644, abs=1e-3)
    with pytest.raises(ValueError):
        B.shape_distance(0.5, 0.0)


def test_rotation_hash_is_stable_and_uniform():
    ys, xs = np.mgrid[0:128, 0:128]
    a = B.rotation_phase(xs, ys, np.full(xs.shape, 100.0))
    np.testing.assert_array_equal(a, B.rotation_phase(xs, ys, np.full(xs.shape, 100.0)))
    assert a.min() >= 0 and a.max() < 2 * math.pi + 1e-6
    hist, _ = np.histogram(a, bins=16, range=(0, 2 * math.pi))
    assert hist.min() > 0.8 * a.size / 16
    assert not np.array_equal(a, B.rotation_phase(xs, ys, np.full(xs.shape, 101.0)))  # a mm deeper reseeds
    # ... but not the depth's last bits, which differ between GPUs (issue 31: llvmpipe vs NVIDIA)
    z = np.full(xs.shape, 100.37, np.float32)
    np.testing.assert_array_equal(B.rotation_phase(xs, ys, z), B.rotation_phase(xs, ys, np.nextafter(z, np.float32(200))))


# ---------------------------------------------------------------------------------------------
# the reference algorithm on small images

PS = 300.0  # pixels per mm at 1 mm depth


def _edge(w=48, h=40, z=40.0, red_only=False):
    E = np.ones((h, w, 3))
    if red_only:
        E[:, w // 2:, 0] = 0.1
    else:
        E[:, w // 2:] = 0.1
    return E, np.full((h, w), z), np.ones((h, w))


PROF = B.profile([0.5] * 3, [0.2, 0.1, 0.05], "direct")


def test_weights_are_one_for_the_widest_channel_t41():
    s = B.sample_set(22)
    S = 1.0 / PROF.d
    w = S / (8 * math.pi) * (np.exp(-S * s.x * PROF.d) + np.exp(-S * s.x * PROF.d / 3)) * s.rcp_pdf * PROF.d
    np.testing.assert_allclose(w, 1.0, atol=1e-12)


@pytest.mark.parametrize("levels,cutoffs", [((12,), ()), ((22,), ()), ((12, 10), (0.25,)), ((6, 8, 16), (0.1, 0.2))])
def test_constant_irradiance_is_preserved_t42(levels, cutoffs):
    E, z, m = _edge()
    E[:] = (0.3, 0.6, 0.9)
    r = B.blur(E, z, m, PROF, PS, B.Sampling(levels, cutoffs))
    np.testing.assert_allclose(r.out, E, rtol=1e-12)
    assert np.all(r.level == 0)  # C = 0: nothing triggers (T6.2)


def test_degenerate_thresholds_t61_and_accounting_t64():
    E, z, m = _edge()
    g12 = B.blur(E, z, m, PROF, PS, B.Sampling((12,)))
    never = B.blur(E, z, m, PROF, PS, B.Sampling((12, 10), (1.0,)))
    always = B.blur(E, z, m, PROF, PS, B.Sampling((12, 10), (-1.0,)))
    np.testing.assert_array_equal(never.out, g12.out)
    n = int(m.sum())
    assert never.count.sum() == 12 * n and always.count.sum() == 22 * n
    mid = B.blur(E, z, m, PROF, PS, B.Sampling((12, 10), (0.25,)))
    trig = int((mid.level > 0).sum())
    assert 0 < trig < n
    assert mid.count.sum() == 12 * n + 10 * trig
    saved = B.samples_saved(mid.count.sum(), 22 * n)
    assert 0 <= saved <= 1 - 12 / 22


def test_contrast_sanity_per_channel_t62():
    E, z, m = _edge(red_only=True)
    r = B.blur(E, z, m, PROF, PS, B.Sampling((12, 10), (0.25,)))
    assert (r.level > 0).any()  # a red-only edge triggers through R alone (any())
    trig = r.level > 0
    assert np.all(r.contrast[trig][:, 1:] == 0) and np.all(r.contrast[trig][:, 0] > 0.25)


def test_threshold_monotonicity_t63():
    E, z, m = _edge()
    fr = [(B.blur(E, z, m, PROF, PS, B.Sampling((12, 10), (t,))).level > 0).mean() for t in (0.0, 0.1, 0.25, 0.5, 0.9)]
    assert all(a >= b for a, b in itertools.pairwise(fr)) and fr[0] > fr[-1]


def test_pixel_cutoff_and_budget_follow_the_kernel_area():
    E, z, m = _edge()
    # kernel radius in px = 16.56 d * PS / z
    for zz, expect_skip in ((40.0, False), (PROF.filter_radius * PS / 1.0, True)):
        r = B.blur(E, np.full(z.shape, zz), m, PROF, PS, B.Sampling((22,), (), budget=True))
        rad = PROF.filter_radius * PS / zz
        n_avail = math.floor(math.pi * rad * rad / 4)
        assert r.skipped.all() == expect_skip
        if expect_skip:
            np.testing.assert_array_equal(r.out, E) and (r.count == 0).all()
        else:
            assert (r.count == min(22, n_avail)).all()
    zz = PROF.filter_radius * PS / 4.0  # radius 4 px: floor(4 pi) = 12 samples
    r = B.blur(E, np.full(z.shape, zz), m, PROF, PS, B.Sampling((22,), (), budget=True))
    assert (r.count == 12).all()


def test_edge_response_reference_values_t43():
    np.testing.assert_allclose(B.edge_response([0.1, 0.5, 1, 2, 5, 10]), [0.5632, 0.6898, 0.7770, 0.8706, 0.9653,
                                                                           0.9949], atol=1e-4)
    np.testing.assert_allclose(B.edge_response(-0.5), 1 - 0.6898, atol=1e-4)


# ---------------------------------------------------------------------------------------------
# issue 36: pins that the mutation run found missing (benchmarks/mutation.py, notes/mutation.md)

def test_nested_sets_keep_golubevs_base_radii_and_complete_one_set():
    """nested_sets (n_base, n_total = m n_base, m odd): the base set has exactly Golubev's n_base radii
    (entries m k + (m - 1)/2 of the n_total set have u = (k + 0.5)/n_base), base and extra together are
    the n_total set, the extra level has no ring flags; m even, < 3 or not whole is refused."""
    for nb, nt in ((6, 30), (10, 30), (4, 20)):
        base, extra = B.nested_sets(nb, nt)
        full = B.sample_set(nt)
        np.testing.assert_allclose(base.x, B.sample_set(nb).x, rtol=1e-12)
        assert base.n == nb and extra.n == nt - nb and len(extra.x) == nt - nb
        np.testing.assert_allclose(np.sort(np.concatenate([base.x, extra.x])), np.sort(full.x), rtol=1e-12)
        np.testing.assert_allclose(np.sort(np.concatenate([base.phi, extra.phi])), np.sort(full.phi))
        np.testing.assert_allclose(base.rcp_pdf * B.polar_pdf_unit(base.x), 1.0)
        np.testing.assert_allclose(extra.rcp_pdf * B.polar_pdf_unit(extra.x), 1.0)
        np.testing.assert_array_equal(base.inner, B.ring_flags(base.x))
        assert not extra.inner.any()
    np.testing.assert_array_equal(B.nested_sets(6, 30, "equal-count")[0].inner, [1, 1, 1, 0, 0, 0])
    for nb, nt in ((6, 24), (6, 31), (6, 6), (5, 10)):
        with pytest.raises(ValueError, match="odd"):
            B.nested_sets(nb, nt)
    s = B.Sampling(levels=(6, 24), cutoffs=(0.25,), nested=True).sets()
    np.testing.assert_allclose(s[0].x, B.nested_sets(6, 30)[0].x)
    assert [x.n for x in s] == [6, 24]
    with pytest.raises(ValueError, match="exactly two levels"):
        B.Sampling(levels=(6, 24, 8), cutoffs=(0.1, 0.2), nested=True).sets()
    # not nested: each level its own stratified set, turned by EXTRA_PHASE per level
    s = B.Sampling(levels=(12, 10), cutoffs=(0.25,), split="equal-count").sets()
    np.testing.assert_allclose(s[1].x, B.sample_set(10).x)
    np.testing.assert_allclose(s[1].phi, B.sample_set(10).phi + B.EXTRA_PHASE)
    assert s[0].inner.sum() == 6
    assert B.Sampling(levels=(12, 10), cutoffs=(0.25,)).max_samples == 22


def test_sampling_refuses_inconsistent_plans():
    with pytest.raises(ValueError, match="one cutoff per extra level"):
        B.Sampling(levels=(12, 10), cutoffs=())
    with pytest.raises(ValueError, match="unknown contrast"):
        B.Sampling(levels=(12,), contrast="nope")
    with pytest.raises(ValueError, match="unknown ring split"):
        B.Sampling(levels=(12,), split="nope")
    with pytest.raises(ValueError, match="1..1024"):
        B.sample_set(0)


def test_contrast_of_rings_and_minmax_values():
    """eq. 4.1 per channel: |L_in - L_out| / (L_in + L_out) of the ring means; 0 for an empty ring;
    minmax: (max - min) / (max + min), 0 where no sample was valid."""
    in_sum = np.array([[3.0, 2.0, 0.0], [1.0, 1.0, 1.0]])
    out_sum = np.array([[2.0, 4.0, 0.0], [1.0, 1.0, 1.0]])
    n_in, n_out = np.array([3, 0]), np.array([4, 2])
    C = B.contrast_of("rings", in_sum, out_sum, n_in, n_out, None, None)
    # pixel 0: L_in = (1, 2/3, 0), L_out = (0.5, 1, 0) -> (1/3, 0.2, 0); pixel 1: empty inner ring -> 0
    np.testing.assert_allclose(C, [[1 / 3, 0.2, 0.0], [0.0, 0.0, 0.0]], atol=1e-12)
    lo = np.array([[0.2, 1.0, np.inf], [np.inf, np.inf, np.inf]])
    hi = np.array([[0.6, 1.0, -np.inf], [-np.inf, -np.inf, -np.inf]])
    C = B.contrast_of("minmax", None, None, None, None, lo, hi)
    np.testing.assert_allclose(C, [[0.5, 0.0, 0.0], [0.0, 0.0, 0.0]], atol=1e-12)


def test_profile_of_a_settings_section_and_its_scale():
    from skinviewer.ground.settings import Settings, with_values
    b = with_values(Settings(), {"burley.fit": "direct", "burley.mfp": [1.0, 2.0, 4.0], "burley.scale": 0.5}).burley
    p = B.profile_of_section(b)
    np.testing.assert_allclose(p.d_rgb, [0.5, 1.0, 2.0])
    np.testing.assert_allclose(p.S, [2.0, 1.0, 0.5])
    assert p.d == 2.0 and p.filter_radius == pytest.approx(2.0 * B.FILTER_RADIUS_UNIT)
    d = Settings().burley
    np.testing.assert_allclose(B.profile_of_section(d).d_rgb, B.shape_distance(d.albedo, d.mfp, d.fit) * d.scale)


def test_pcg_hash_and_rotation_phase_equal_the_shader(gl_ctx):
    """The numpy twins are bit-exact with shaders/lib/burley.glsl evaluated on the GPU (the hash as two
    16-bit halves, exact in float32; the phase to float32 rounding)."""
    from glsl_eval import glsl_eval
    from test_glsl_pins import BURLEY_PREAMBLE
    v = np.array([0, 1, 2, 12345, 2**31 - 1, 2**32 - 1, 747796405, 99], np.uint32)
    got = glsl_eval(gl_ctx, "lib/burley.glsl", "vec4(float(burley_pcg(uint(a.x) * 65536u + uint(a.y)) >> 16u), "
                    "float(burley_pcg(uint(a.x) * 65536u + uint(a.y)) & 65535u), 0.0, 0.0)",
                    np.stack([v >> 16, v & 0xFFFF], 1).astype(np.float64), preamble=BURLEY_PREAMBLE)
    h = B.pcg_hash(v)
    np.testing.assert_array_equal(got[:, 0].astype(np.uint32) * 65536 + got[:, 1].astype(np.uint32), h)
    assert len(set(h.tolist())) == len(v)  # no collisions among these
    ys, xs = np.mgrid[0:4, 0:6]
    z = np.linspace(37.0, 912.5, xs.size).reshape(xs.shape).astype(np.float32)
    pts = np.stack([xs.ravel(), ys.ravel(), z.ravel()], 1).astype(np.float64)
    ph = glsl_eval(gl_ctx, "lib/burley.glsl", "vec4(burley_phase(ivec2(a.xy), a.z), 0.0, 0.0, 0.0)", pts,
                   preamble=BURLEY_PREAMBLE)[:, 0]
    np.testing.assert_allclose(ph, B.rotation_phase(xs, ys, z).ravel(), rtol=1e-6, atol=1e-6)


# ---------------------------------------------------------------------------------------------
# issue 36, second round: blur() against a scalar per-pixel reference written from the spec (§5.3 steps
# 3-4, §7.5-7.6), not from blur(): the radii by root-finding on eq. 3.9 (not the analytic inverse), the
# pdf as the CDF's numerical derivative, the weight as R(r') r' / pdf with profiles.burley_normalized
# (eq. 2.83), the direction as phi + psi (not a rotation matrix), one pixel and one sample at a time.

def _ref_table(n, phase=0.0):
    from scipy.optimize import brentq

    from skinviewer.physics.profiles import burley_cdf
    x = np.array([brentq(lambda t, p=(i + 0.5) / n: float(burley_cdf(t)) - p, 0.0, 200.0, xtol=1e-14, rtol=1e-15)
                  for i in range(n)])
    phi = np.array([2 * math.pi * math.modf(i / ((1 + math.sqrt(5)) / 2))[0] + phase for i in range(n)])
    return x, phi


def _ref_inner(x, split):
    if split == "half-radius":
        return x <= x.max() / 2
    if split == "area-third":  # inner:outer area 1:3 -> R_in = R / sqrt(3)
        return x <= x.max() / math.sqrt(3)
    return np.arange(len(x)) < (len(x) + 1) // 2


def _ref_pdf_unit(x, h=1e-5):
    """p(r, phi) per unit x = r/d and radian: dP/dx / (2 pi), P of eq. 3.9, by central differences."""
    from skinviewer.physics.profiles import burley_cdf
    return float(burley_cdf(x + h) - burley_cdf(x - h)) / (2 * h) / (2 * math.pi)


def _ref_blur(E, z, mask, prof, ps, levels, cutoffs=(), split="half-radius", contrast="rings", budget=False,
              nested=False, wide_px=1e30, wide_scale=1.0, seed=0):
    from scipy.optimize import brentq

    from skinviewer.physics.profiles import burley_cdf, burley_normalized
    H, W = z.shape
    z32 = np.asarray(z, np.float32)
    d, d_rgb = float(np.max(prof.d_rgb)), np.asarray(prof.d_rgb, float)
    radius_unit = brentq(lambda t: float(burley_cdf(t)) - 0.997, 0.0, 200.0, xtol=1e-14)  # spec §5.3: P^-1(0.997)
    if nested:  # one stratified set of levels[0] + levels[1]; the base is every m-th entry from (m-1)/2
        xf, pf = _ref_table(sum(levels))
        m = sum(levels) // levels[0]
        pick = [m * k + (m - 1) // 2 for k in range(levels[0])]
        rest = [i for i in range(sum(levels)) if i not in pick]
        tables = [(xf[pick], pf[pick]), (xf[rest], pf[rest])]
    else:  # level k turned by k half golden angles (spec §7.6)
        golden_angle = math.pi * (3 - math.sqrt(5))
        tables = [_ref_table(n, k * golden_angle / 2) for k, n in enumerate(levels)]
    inner0 = _ref_inner(tables[0][0], split)
    out, count = E.astype(float).copy(), np.zeros((H, W), int)
    level, skipped, C_img = np.zeros((H, W), int), np.zeros((H, W), bool), np.full((H, W, 3), np.nan)

    def contrast_now(vals):
        if contrast == "rings":  # eq. 4.1 between the ring means of the valid base samples
            ins = [e for e, f in vals if f is True]
            outs = [e for e, f in vals if f is False]
            if not ins or not outs:
                return np.zeros(3)
            a, b = np.mean(ins, axis=0), np.mean(outs, axis=0)
            return np.abs(a - b) / np.maximum(a + b, 1e-6)
        if not vals:
            return np.zeros(3)
        es = np.array([e for e, _ in vals])
        lo, hi = es.min(axis=0), es.max(axis=0)
        return (hi - lo) / np.maximum(hi + lo, 1e-6)

    for py in range(H):
        for px in range(W):
            if mask[py, px] <= 0.5:
                continue
            zp = float(z32[py, px])
            ppm = ps / zp
            rad_px = radius_unit * d * ppm
            n_avail = math.floor(math.pi * rad_px ** 2 / 4)  # one sample per 4 px of the kernel's area
            if n_avail < 1:
                skipped[py, px] = True
                continue
            psi = float(B.rotation_phase(np.array([px]), np.array([py]), np.array([zp], np.float32), seed)[0])
            acc, ws, vals = np.zeros(3), np.zeros(3), []

            def take(x, phi, flag, px=px, py=py, ppm=ppm, psi=psi, zp=zp, acc=acc, ws=ws, vals=vals):
                count[py, px] += 1
                r = x * d
                qx = px + math.floor(ppm * r * math.cos(phi + psi) + 0.5)
                qy = py + math.floor(ppm * r * math.sin(phi + psi) + 0.5)
                if not (0 <= qx < W and 0 <= qy < H) or mask[qy, qx] <= 0.5:
                    return
                dz = float(z32[qy, qx]) - zp
                rp = math.sqrt(r * r + dz * dz)
                w = burley_normalized(rp, d_rgb) * rp * d / _ref_pdf_unit(x)
                acc[:] += w * E[qy, qx]
                ws[:] += w
                vals.append((E[qy, qx], flag))

            if budget and n_avail < levels[0]:
                for x, phi in zip(*_ref_table(n_avail)):
                    take(x, phi, None)
            else:
                for x, phi, f in zip(*tables[0], inner0):
                    take(x, phi, bool(f))
                if len(levels) > 1 and (not budget or n_avail >= sum(levels)):
                    C = contrast_now(vals)
                    C_img[py, px] = C
                    s = wide_scale if rad_px >= wide_px else 1.0
                    k = 1
                    while k < len(levels) and np.any(C > cutoffs[k - 1] * s):
                        for x, phi in zip(*tables[k]):
                            take(x, phi, None)
                        level[py, px] = k
                        C = contrast_now([v for v in vals if v[1] is not None] if contrast == "rings" else vals)
                        k += 1
            out[py, px] = acc / np.maximum(ws, np.finfo(np.float32).tiny)
    return out, count, level, skipped, C_img


def _ref_scene():
    """10 x 12 px: noisy irradiance with an edge (float32 values), a hole in the SSS mask and one pixel at
    mask 0.5 (not SSS), rows 0-4 in four depth bands (kernel radius 6.6, 4.5, 3.3 and 2 px: 34, 16, 8 and 3
    samples' worth), then one row per boundary case: exactly 22, 12, 6 and 1 samples' worth (the budget's
    and the levels' edges), and a row too far for any sample (skipped). Sub-mm depth noise: dz matters."""
    rng = np.random.default_rng(36)
    H, W = 10, 12
    E = np.array([0.5, 0.4, 0.3]) * rng.uniform(0.8, 1.2, (H, W, 3))
    E[:, :4] *= 3.0  # a contrast edge
    E = E.astype(np.float32).astype(np.float64)
    z = np.repeat(np.array([150.0] * 5 + [220.0] * 3 + [300.0] * 2 + [500.0] * 2)[None, :], H, axis=0)
    # radius 993.9 / z px: floor(pi r^2 / 4) = 22, 12, 6, 1 samples at 186, 250, 345, 700 mm (+ 0.6 mm)
    z[5:9] = np.array([186.0, 250.0, 345.0, 700.0])[:, None]
    z += rng.uniform(0.0, 0.6, (H, W))
    z[9] = 1500.0
    mask = np.ones((H, W))
    mask[3:5, 2:4] = 0.0
    mask[7, 10] = 0.0
    mask[1, 1] = 0.5
    return E, z, mask


@pytest.mark.parametrize("kw", [
    dict(levels=(12, 10), cutoffs=(0.2,)),
    dict(levels=(12, 10), cutoffs=(0.2,), contrast="minmax", budget=True),
    dict(levels=(6, 8, 16), cutoffs=(0.1, 0.3), contrast="minmax", split="area-third"),
    dict(levels=(6, 8, 16), cutoffs=(0.05, 0.15), wide_px=5.0, wide_scale=0.5),
    dict(levels=(6, 24), cutoffs=(0.15,), nested=True, split="equal-count"),
    dict(levels=(6, 24), cutoffs=(0.15,), nested=True, budget=True),
    dict(levels=(12, 10), cutoffs=(0.3,), wide_px=5.0, wide_scale=0.5, seed=7),
    dict(levels=(22,), budget=True),
], ids=["rings", "minmax-budget", "three-levels-minmax", "three-levels-rings", "nested", "nested-budget", "wide-seed",
                                "golubev"])
def test_blur_equals_a_scalar_reference_from_the_spec(kw):
    E, z, mask = _ref_scene()
    prof = B.profile([0.5] * 3, [0.2, 0.1, 0.05], "direct")
    ref_out, ref_count, ref_level, ref_skip, ref_C = _ref_blur(E, z, mask, prof, PS, **kw)
    r = B.blur(E.astype(np.float32), z, mask, prof, PS, B.Sampling(**kw))  # float32 in, float64 out
    assert r.out.dtype == np.float64 and r.count.dtype.kind == "i" and r.level.dtype.kind == "i"
    np.testing.assert_array_equal(r.skipped, ref_skip)
    np.testing.assert_array_equal(r.count, ref_count)
    np.testing.assert_array_equal(r.level, ref_level)
    # tolerance: the reference's pdf is a central difference (~1e-10 relative); a wrong weight is >= 1e-3
    np.testing.assert_allclose(r.out, ref_out, rtol=1e-7, atol=1e-12)
    np.testing.assert_allclose(r.contrast, ref_C, rtol=1e-9, atol=1e-12)  # nan (not computed) in the same places
    # the scene exercises what it claims: skipped pixels, more than one level, untouched non-SSS pixels
    assert ref_skip.any() and (ref_count > 0).any()
    np.testing.assert_array_equal(r.out[mask <= 0.5], E[mask <= 0.5])
    if len(kw["levels"]) > 1:
        assert 0 < (ref_level > 0).sum() < (ref_count > 0).sum()


def _pcg_py(v: int) -> int:
    """PCG-RXS-M-XS 32 (Jarzynski & Olano 2020) in Python integers, masked to 32 bits."""
    m = 0xFFFFFFFF
    state = (v * 747796405 + 2891336453) & m
    word = (((state >> ((state >> 28) + 4)) ^ state) * 277803737) & m
    return ((word >> 22) ^ word) & m


def test_edges_of_the_small_functions():
    """The boundaries and defaults the mutation run found unpinned (notes/mutation.md): each line is an
    independent value, not a re-run of the code."""
    # the hash on plain Python integers equals the reference in Python integers
    vs = [0, 1, 99, 12345, 2**31 - 1, 2**32 - 1]
    np.testing.assert_array_equal(B.pcg_hash(vs), [_pcg_py(v) for v in vs])
    # the rotation phase: float32 like the GLSL (the depth too: 100.99999999 mm is 101.0 in float32)
    ph = B.rotation_phase(np.array([3]), np.array([4]), np.array([100.99999999]))
    assert ph.dtype == np.float32
    np.testing.assert_array_equal(ph, B.rotation_phase(np.array([3]), np.array([4]), np.array([101.0], np.float32)))
    # pixels per mm below 1 mm of depth
    assert B.pixel_scale(np.array([0.5]), 300.0)[0] == pytest.approx(600.0)
    # ring splits are inclusive at the boundary: r = R/2 and r = R/sqrt(3) are inner
    np.testing.assert_array_equal(B.ring_flags(np.array([1.0, 2.0])), [True, False])
    np.testing.assert_array_equal(B.ring_flags(np.array([1.0, math.sqrt(3.0)]), "area-third"), [True, False])
    with pytest.raises(ValueError, match="known: half-radius, area-third, equal-count"):
        B.ring_flags(np.ones(2), "nope")
    # the extra level of a nested pair has boolean (all False) ring flags, like every set
    assert B.nested_sets(6, 30)[1].inner.dtype == bool
    # 1..1024 samples, both ends included
    assert B.sample_set(1).n == 1 and B.sample_set(1024).n == 1024
    assert B.sample_set(1).x[0] == pytest.approx(B.inverse_cdf(0.5))
    with pytest.raises(ValueError):
        B.sample_set(1025)
    # sample reduction with fractional totals (mean samples per pixel)
    assert B.samples_saved(0.25, 0.5) == pytest.approx(0.5)
    # the default fit is searchlight + diffuse mean free path, eq. 2.88: s = 3.5 + 100 (A - 0.33)^4
    s_A = 3.5 + 100.0 * (0.6 - 0.33) ** 4
    np.testing.assert_allclose(B.shape_distance([0.6] * 3, 2.0), 2.0 / s_A)
    np.testing.assert_allclose(B.profile([0.6] * 3, [1.0, 2.0, 3.0]).d_rgb, np.array([1.0, 2.0, 3.0]) / s_A)
    # direct: per-channel distances broadcast from one mfp, as floats
    d = B.shape_distance([0.3, 0.4, 0.5], 2, "direct")
    assert d.dtype == np.float64 and d.shape == (3,)
    np.testing.assert_array_equal(d, [2.0, 2.0, 2.0])
    with pytest.raises(ValueError, match="finite and > 0 mm"):
        B.shape_distance(0.5, float("nan"))
    # the quadrature and the thick mode away from S = 1, A = 1 (where t and S, or A, could swap unseen)
    assert B.transmittance_numeric(1.0, 2.0, 0.5) == pytest.approx(0.5 * 0.25 * (math.exp(-2) + 3 * math.exp(-2 / 3)),
                                                                  rel=1e-6)
    S = np.array([0.5, 2.0, 3.0])
    np.testing.assert_allclose(B.transmittance_thick(0.7, 2.0, S, 0.4),
                               0.1 * (np.exp(-0.7 * S) + 3 * np.exp(-0.7 * S / 3)) * np.exp(-1.3 * S / 3))
    # the edge response at the edge itself is one half
    assert B.edge_response(0.0) == 0.5
    with pytest.raises(ValueError, match="one cutoff per extra level"):
        B.Sampling(levels=(12, 10))
    with pytest.raises(ValueError, match="nested sampling has exactly two levels"):
        B.Sampling(levels=(4, 8, 12), cutoffs=(0.1, 0.2), nested=True).sets()


def test_contrast_of_single_samples_and_dim_rings():
    """eq. 4.1 with one valid sample in a ring (its mean is that sample) and with dim irradiance (the
    1e-6 floor only guards 0/0)."""
    in_sum = np.array([[0.02, 0.3, 0.001]])
    out_sum = np.array([[0.06, 0.3, 0.004]])
    C = B.contrast_of("rings", in_sum, out_sum, np.array([1]), np.array([1]), None, None)
    np.testing.assert_allclose(C, [[0.5, 0.0, 0.6]], atol=1e-12)
    C = B.contrast_of("rings", in_sum, out_sum * 2, np.array([1]), np.array([2]), None, None)
    np.testing.assert_allclose(C, [[0.5, 0.0, 0.6]], atol=1e-12)
