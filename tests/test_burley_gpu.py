"""The Burley blur passes on the GPU (shaders/lib/burley.glsl) on synthetic screen-space buffers:
spec §12.4 (T4.1-T4.7) and §12.6 (T6.1-T6.4), and agreement with the numpy reference."""
from __future__ import annotations

import itertools
import math

import numpy as np
import pytest
from burley_gpu import Harness, plane, proj_scale

from skinviewer.passes import burley as PB
from skinviewer.physics import burley as B

DIRECT = {"burley.fit": "direct", "burley.budget": False}


def _mfp(d):
    return {"burley.mfp": list(np.broadcast_to(np.asarray(d, float), (3,)))}


@pytest.fixture
def harness(gl_ctx):
    made = []

    def make(variant="golubev", plan=None):
        h = Harness(gl_ctx, PB.BurleyBlurPass(variant, plan))
        made.append(h)
        return h

    yield make
    for h in made:
        h.release()


def _scene(w=80, h=64, seed=1):
    """Irradiance with edges, noise, a depth step and mask holes (not SSS) plus background."""
    rng = np.random.default_rng(seed)
    E = np.ones((h, w, 3)) * (0.8, 0.6, 0.5)
    E[:, w // 2:] *= 0.15
    E[h // 3: h // 2, :, 0] *= 3.0
    E *= 1.0 + 0.2 * rng.random((h, w, 1))
    z = np.full((h, w), 200.0)
    z[:, : w // 4] = 203.0
    mask = np.ones((h, w))
    mask[5:12, 40:50] = 0.0
    mask[:, -6:] = 0.0
    return E, z, mask


def _profile(d_rgb):
    return B.Profile(np.asarray(d_rgb, float))


D_RGB = (0.6, 0.35, 0.2)


@pytest.mark.parametrize("variant,plan,assign", [
    ("golubev", None, {"burley.samples": 12}),
    ("golubev", None, {"burley.samples": 22, "burley.budget": True}),
    ("two_level", None, {}),
    ("two_level", None, {"burley2.split": "equal-count", "burley2.threshold": 0.1}),
    ("two_level", None, {"burley2.threshold": 0.1, "burley2.wide_px": 5.0, "burley2.wide_scale": 2.5}),
    ("two_level", None, {"burley2.mode": "nested", "burley2.base": 6, "burley2.extra": 24, "burley2.contrast": "minmax"}),
    ("two_level", None, {"burley2.mode": "three-level", "burley2.base": 6, "burley2.extra": 8, "burley2.third": 16,
                         "burley2.contrast": "minmax", "burley2.threshold": 0.2, "burley2.threshold2": 0.3}),
])
def test_glsl_matches_the_numpy_reference(harness, variant, plan, assign):
    E, z, mask = _scene()
    h = harness(variant, plan)
    a = {**DIRECT, **_mfp(D_RGB), **assign}
    out, stats, cnt = h.run(E, z, mask, **a)
    from skinviewer.ground.settings import Settings, with_values
    s = with_values(Settings(), a)
    pl = PB.golubev_plan(s.burley) if variant == "golubev" else PB.two_level_plan(s.burley2)
    ref = B.blur(E, z, mask, _profile(D_RGB), proj_scale(z.shape[0]), pl.sampling(s.burley.budget))
    agree = np.all(np.abs(out - ref.out) <= 2e-4 * np.maximum(1.0, np.abs(ref.out)), axis=-1)
    assert agree.mean() > 0.995, f"{(~agree).sum()} pixels differ"
    same_count = stats[..., 0] == ref.count
    assert same_count.mean() > 0.995
    assert cnt.samples == int(stats[..., 0].sum()) and cnt.pixels == int((stats[..., 0] > 0).sum())
    np.testing.assert_array_equal(out[mask <= 0.5], E[mask <= 0.5].astype(np.float32))  # non-SSS untouched


def test_weights_t41_and_energy_t42(harness):
    # constant irradiance -> exactly E for any n, depth or rotation (normalisation by the weight sum)
    for n in (1, 7, 22, 30):
        h = harness()
        for zz in (150.0, 400.0):
            E, z, mask = plane(40, 32, zz)
            E = E * (0.25, 0.5, 1.0)
            out, _, _ = h.run(E, z, mask, **DIRECT, **_mfp(D_RGB), **{"burley.samples": n})
            np.testing.assert_allclose(out, E, rtol=2e-6)


def _edge_run(h, n, rows=4096, w=136, x0=68, dpx=2.5):
    z = 100.0
    d = dpx * z / proj_scale(rows)
    E = np.zeros((rows, w, 3))
    E[:, x0:] = 1.0
    out, _, _ = h.run(E, np.full((rows, w), z), np.ones((rows, w)),
                          **DIRECT, **_mfp(d), **{"burley.samples": n})
    t = (np.arange(w) + 0.5 - x0) / dpx
    return t, out[..., 0]


def _ideal(n, t):
    """The rotation-averaged estimator of stratified radii x_i: mean_i P(x_i cos(theta) >= -t)."""
    x = B.sample_set(n).x
    t = np.asarray(t, float)[..., None]
    frac = np.where(x > np.abs(t), 1.0 - np.arccos(np.clip(np.abs(t) / x, -1, 1)) / math.pi, 1.0)
    lit = frac.mean(-1)
    return np.where(t[..., 0] >= 0, lit, 1.0 - lit)


T_SPEC = np.array([0.1, 0.5, 1.0, 2.0, 5.0, 10.0])


@pytest.mark.parametrize("n,tol,noise", [(12, 0.005, 0.057), (22, 0.002, 0.035), (30, 0.001, 0.025)])
def test_edge_convergence_t43_and_noise_t44(harness, n, tol, noise):
    t, img = _edge_run(harness(), n)
    est, sd = img.mean(0), img.std(0)
    sel = np.abs(t) <= 10.5
    # the GPU is the rotation-averaged stratified estimator, up to the noise of 4096 phases
    err = np.abs(est - _ideal(n, t))[sel]
    assert np.all(err <= 4.0 * sd[sel] / math.sqrt(img.shape[0]) + 2e-4), err.max()
    # that estimator against the analytic edge response (spec T4.3), both sides of the edge
    bias = np.abs(np.concatenate([_ideal(n, T_SPEC) - B.edge_response(T_SPEC),
                                  _ideal(n, -T_SPEC) - B.edge_response(-T_SPEC)]))
    allowed = np.full(bias.shape, tol)
    if n == 12:
        # the spec's 0.0042 "maximum bias" for 12 samples misses two points: at t = 0.1 d the nearest radius
        # (0.086 d) is too coarse (0.0072), and no radius reaches t = 10 d (largest 8.67 d): 1 - 0.9949
        allowed[[0, 5, 6, 11]] = [0.0075, 0.0055, 0.0075, 0.0055]
    assert np.all(bias <= allowed), bias
    # noise at the edge (spec T4.4: 0.057 / 0.032-0.038 / 0.025 of the step, +-25 %)
    edge_sd = sd[np.argmin(np.abs(t - 0.2))]
    assert 0.75 * noise <= edge_sd <= 1.25 * noise


def test_pixel_cutoff_is_bit_identical_and_budget_follows_area_t45(harness):
    w, hgt = 48, 40
    rng = np.random.default_rng(3)
    E = rng.random((hgt, w, 3)).astype(np.float32).astype(np.float64)
    d = 0.5
    ps = proj_scale(hgt)
    h = harness()
    for radius_px, expect in ((1.0, "skip"), (1.2, 1), (4.0, 12), (6.0, 22), (30.0, 22)):
        z = B.FILTER_RADIUS_UNIT * d * ps / radius_px
        out, stats, cnt = h.run(E, np.full((hgt, w), z), np.ones((hgt, w)),
                                **{"burley.fit": "direct", "burley.budget": True, **_mfp(d), "burley.samples": 22})
        if expect == "skip":
            np.testing.assert_array_equal(out, E.astype(np.float32))  # bit for bit
            assert cnt.samples == 0 and cnt.skipped == w * hgt and cnt.pixels == 0
        else:
            assert np.all(stats[..., 0] == expect) and cnt.skipped == 0
            assert expect == min(22, math.floor(math.pi * radius_px ** 2 / 4))


def test_no_background_bleeding_t46(harness):
    w, hgt = 64, 48
    E = np.ones((hgt, w, 3)) * 0.7
    E[:, 40:] = 0.0  # black background
    z = np.full((hgt, w), 100.0)
    z[:, 40:] = 1e4
    mask = np.zeros((hgt, w))
    mask[:, :40] = 1.0
    d = 1.0
    out, _, _ = harness().run(E, z, mask, **DIRECT, **_mfp(d), **{"burley.samples": 22})
    assert (B.FILTER_RADIUS_UNIT * d * proj_scale(hgt) / 100.0) > 10  # the kernel crosses the silhouette
    np.testing.assert_array_equal(out[:, 40:], 0.0)  # background unchanged
    assert np.all(out[:, :40] >= 0.7 * 0.99)  # SSS pixels near the silhouette not darkened by more than 1 %


def test_depth_bilateral_t47(harness):
    """Two planes Delta z apart: the far plane's contribution to the near plane's pixels is the profile at
    r' = sqrt(r^2 + dz^2): <= 1 % of the weight at dz = filter radius, <= 0.05 % at 30 d."""
    w, hgt = 96, 96
    d = 1.0
    z0 = 100.0
    dpx = d * proj_scale(hgt) / z0
    assert B.FILTER_RADIUS_UNIT * dpx > 20
    h = harness()
    for dz, limit in ((B.FILTER_RADIUS_UNIT * d, 0.01), (30 * d, 0.0005)):
        E = np.zeros((hgt, w, 3))
        E[:, w // 2:] = 1.0  # the other plane carries irradiance 1: the output is its share of the weight
        z = np.full((hgt, w), z0)
        z[:, w // 2:] += dz
        out, _, _ = h.run(E, z, np.ones((hgt, w)), **DIRECT, **_mfp(d), **{"burley.samples": 22})
        share = out[:, w // 2 - 1, 0].mean()  # pixels at the step: half the disk on the far plane
        assert share <= limit, (dz, share)
    # the numpy reference's weights are the polar-form profile at r' (checked to 1e-4 against the GPU above)
    E = np.zeros((hgt, w, 3))
    E[:, w // 2:] = 1.0
    z = np.full((hgt, w), z0)
    z[:, w // 2:] += 2 * d
    out, _, _ = h.run(E, z, np.ones((hgt, w)), **DIRECT, **_mfp(d), **{"burley.samples": 22})
    ref = B.blur(E, z, np.ones((hgt, w)), _profile((d, d, d)), proj_scale(hgt), B.Sampling((22,)))
    np.testing.assert_allclose(out, ref.out, atol=1e-4)


def test_degenerate_two_level_is_golubev_bit_for_bit_t61(harness):
    E, z, mask = _scene(seed=5)
    a = {**DIRECT, **_mfp(D_RGB)}
    g12, _, c12 = harness().run(E, z, mask, **a, **{"burley.samples": 12})
    never, _, cn = harness("two_level").run(E, z, mask, **a, **{"burley2.threshold": 1.0})
    np.testing.assert_array_equal(never, g12)
    n = c12.pixels
    assert c12.samples == 12 * n and cn.samples == 12 * n and cn.triggered == 0
    pooled, _, cp = harness("golubev", PB.Plan((12, 10), ((0.0,) * 3,), always=True)).run(E, z, mask, **a)
    always, _, ca = harness("two_level").run(E, z, mask, **a, **{"burley2.threshold": -1.0})
    np.testing.assert_array_equal(always, pooled)
    assert ca.samples == 22 * n and cp.samples == 22 * n and ca.triggered == n


def test_contrast_sanity_t62_monotonicity_t63_accounting_t64(harness):
    w, hgt = 64, 48
    a = {**DIRECT, **_mfp(D_RGB)}
    h = harness("two_level")
    E, z, mask = plane(w, hgt, 200.0)
    _, stats, c = h.run(E * 0.4, z, mask, **a)
    assert c.triggered == 0 and np.all(stats[..., 3] == 0)  # constant irradiance: C = 0, nothing triggers
    E = np.ones((hgt, w, 3))
    E[:, w // 2:, 0] = 0.05  # red-only edge
    _, stats, c = h.run(E, z, mask, **a)
    assert c.triggered > 0  # any(): R alone triggers
    E, z, mask = _scene()
    fr = []
    for t in (-1.0, 0.0, 0.1, 0.25, 0.5, 1.0):
        _, stats, c = h.run(E, z, mask, **a, **{"burley2.threshold": t})
        assert c.samples == 12 * c.pixels + 10 * c.triggered  # T6.4
        assert c.triggered == int((stats[..., 1] > 0.5).sum())
        fr.append(c.triggered / c.pixels)
        saved = B.samples_saved(c.samples, 22 * c.pixels)
        assert -1e-12 <= saved <= 1 - 12 / 22 + 1e-12
    assert fr[0] == 1.0 and fr[-1] == 0.0
    assert all(x >= y for x, y in itertools.pairwise(fr))  # fewer triggers as the cutoff rises


def test_sample_count_reaches_the_pass_report(harness):
    E, z, mask = _scene()
    h = harness("two_level")
    h.run(E, z, mask, **DIRECT, **_mfp(D_RGB))
    rec = next(p for p in h.graph.last_report.passes if p.name == "burley_count")
    assert rec.figures["samples"] == h.count.last.samples > 0
    assert "samples on the GPU" in rec.note and f"{h.count.last.samples:,}" in rec.note
    assert "burley_count" in h.graph.last_report.table()


def _iff_above(level, C, t):
    """level > 0 iff C > t, except where the f2 statistics texture rounded C onto the other side of t
    (|C - t| within half a half-float ulp, 2^-11 relative): those may go either way and are few."""
    near = np.abs(C - t) <= 2.0 ** -11 * max(abs(t), 1e-3)
    assert near.mean() < 0.01
    np.testing.assert_array_equal((level > 0.5)[~near], (C > t)[~near])


def test_extra_samples_iff_contrast_above_the_default_threshold_on_the_gpu(harness):
    """Algorithm 1 on the GPU with the default settings (threshold not assigned): a pixel takes the extra
    level iff the base contrast the pass writes (stats.a = max_c C_c, eq. 4.1) exceeds 0.25, the thesis's
    cutoff (seed 001 §4.3; spec §7.4: C > 0.25 under either reading of the offset). Pixels on both sides of
    0.25 and between 0.25 and 0.5 are present, so a changed default or comparison fails."""
    from skinviewer.ground.settings import Settings
    assert Settings().burley2.threshold == 0.25 and Settings().burley2.channel_scale == (1.0, 1.0, 1.0)
    E, z, mask = _scene()
    h = harness("two_level")
    _, stats, _ = h.run(E, z, mask, **DIRECT, **_mfp(D_RGB))
    sss = stats[..., 0] > 0
    C, level, count = stats[..., 3][sss], stats[..., 1][sss], stats[..., 0][sss]
    assert np.all(C >= 0.0)
    assert ((C > 0.26) & (C < 0.49)).sum() >= 20 and (C < 0.24).sum() >= 20 and (C > 0.51).sum() >= 1
    _iff_above(level, C, 0.25)
    np.testing.assert_array_equal(count, np.where(level > 0.5, 22, 12))
    # an assigned threshold moves the cutoff, the comparison still on the written contrast
    _, stats, _ = h.run(E, z, mask, **DIRECT, **_mfp(D_RGB), **{"burley2.threshold": 0.1})
    _iff_above(stats[..., 1][sss], stats[..., 3][sss], 0.1)
