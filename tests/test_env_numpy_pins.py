"""The environment's numpy maths that only the renders exercised (issue 36: physics/environment.py's
mutation sample): specular occlusion's formula, the pre-filtered levels' layout and their read-back, the
truth's weighted unoccluded irradiance, an empty mesh's transfer. Each against a closed form."""
from __future__ import annotations

import math

import numpy as np
import pytest

from skinviewer.physics import environment as env


def test_specular_occlusion_is_lagarde_eq_9_by_hand():
    """clamp((N.V + ao)^(2^(-16 m - 1)) - 1 + ao, 0, 1) (Lagarde & de Rousiers 2014 eq. 9), evaluated by hand."""
    got = env.specular_occlusion(np.array([0.5, 0.3, 1.0, 0.0, 2.0, -1.0]), np.array([0.5, 0.2, 0.0, 1.0, 0.1, 0.1]),
                                 np.array([0.0, 0.25, 0.3, 0.5, 0.25, 0.25]))
    want = [1.0 ** 0.5 - 0.5,                # m = 0: exponent 1/2
            0.5 ** (1 / 32) - 0.8,           # m = 1/4: exponent 2^-5
            0.0,                             # N.V = 1, no ao: 1^p - 1 + 0
            1.0,                             # ao = 1: clamped to 1
            1.1 ** (1 / 32) - 0.9,           # N.V clamped to 1
            max(0.1 ** (1 / 32) - 0.9, 0.0)]  # N.V clamped to 0
    np.testing.assert_allclose(got, want, rtol=1e-12, atol=1e-15)


def test_prefiltered_levels_layout_and_their_read_back():
    """An environment L(w) = 1 + w_y: a lobe symmetric about R averages it to 1 + c_m R_y, c_m the lobe's mean
    cosine (< 1, falling with m). So each level, laid out (H, W) as the equirect texel centres' directions,
    is 1 + c R_y with one c per level; and sample_prefiltered between levels is linear in the level index
    (np.interp over SPEC_LEVELS_M), clamped past the ends."""
    h, w = 64, 128
    img = 1.0 + np.repeat(env.equirect_directions(w, h)[..., 1:2], 3, axis=2)
    pre = env.prefilter_specular(img, size=(32, 16), src_w=64)
    L = len(env.SPEC_LEVELS_M)
    assert pre.shape == (L * 16, 32, 3) and pre.dtype == np.float32
    dy = env.equirect_directions(32, 16)[..., 1]
    cs = []
    for k in range(L):
        lev = pre[k * 16:(k + 1) * 16, :, 0].astype(np.float64) - 1.0
        c = float((lev * dy).sum() / (dy * dy).sum())
        assert np.abs(lev - c * dy).max() < 2e-3 * c, k  # measured 3e-4 of c at most (the texel grids)
        cs.append(c)
    assert 0.0 < cs[-1] < cs[0] < 1.0 and all(np.diff(cs) < 0)
    # read-back: constant levels c_l -> np.interp(m, levels, c); the GLSL's linear blend between levels
    flat = np.concatenate([np.full((16, 32, 3), float(k + 1)) for k in range(L)])
    R = np.tile([[0.0, 0.0, 1.0]], (5, 1))
    m = np.array([0.0, 0.08, 0.2, 0.6, 5.0])
    got = env.sample_prefiltered(flat, R, m)
    np.testing.assert_allclose(got, np.repeat(np.interp(m, env.SPEC_LEVELS_M, np.arange(1, L + 1))[:, None], 3, 1),
                               rtol=1e-12)
    # and a level's texels come back where they were written: level 0 of the gradient at +y, -y and the horizon
    up = env.sample_prefiltered(pre, np.array([[0.0, 1.0, 0.0], [0.0, -1.0, 0.0], [1.0, 0.0, 0.0]]), np.full(3, 0.08))
    np.testing.assert_allclose(up[:, 0], [1 + cs[0] * dy[0].mean(), 1 - cs[0] * dy[0].mean(), 1.0], atol=0.02 * cs[0])


def test_unoccluded_irradiance_with_a_weight_per_direction_and_row():
    """EnvSampler.unoccluded(N, weight): sum_t L_t max(N.w_t, 0) weight(mu, rows) Omega_t. White light:
    weight 1 gives pi; weight = mu gives int cos^2 dw = 2 pi / 3; a weight per row (the slice it is given,
    in chunks) scales each row's pi."""
    s = env.EnvSampler(np.ones((64, 128, 3)), width=128)
    N = np.array([[0.0, 1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.6, 0.8, 0.0], [0.0, -1.0, 0.0]])
    np.testing.assert_allclose(s.unoccluded(N), math.pi, rtol=2e-3)
    np.testing.assert_allclose(s.unoccluded(N, lambda mu, sl: mu), 2 * math.pi / 3, rtol=2e-3)
    rows = np.arange(1.0, 6.0)
    got = s.unoccluded(N, lambda mu, sl: rows[sl][:, None] * np.ones_like(mu), chunk=2)
    np.testing.assert_allclose(got, math.pi * rows[:, None] * np.ones((1, 3)), rtol=2e-3)


def test_transfer_of_an_empty_mesh_is_the_unoccluded_one_in_float32():
    P = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0]])
    N = np.array([[0.0, 0.0, 1.0], [0.0, 1.0, 0.0]])
    T = env.bake_transfer(P, N, np.zeros((0, 3), np.int64))
    assert T.dtype == np.float32 and T.shape == (2, 25)
    np.testing.assert_allclose(T, env.transfer_unoccluded(N), rtol=1e-6, atol=1e-7)
    assert env.transfer_ao(T) == pytest.approx([1.0, 1.0], rel=1e-6)


def test_transfer_and_occlusion_come_out_in_their_documented_precision():
    """bake_transfer returns float32 (the vertex attribute it becomes) for a real mesh too; specular_occlusion
    computes in float64 whatever the precision of N.V (a float32 G-buffer read-back)."""
    P = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
    N = np.tile([0.0, 0.0, 1.0], (3, 1))
    T = env.bake_transfer(P, N, np.array([[0, 1, 2]]), rays=4)
    assert T.dtype == np.float32 and T.shape == (3, 25)
    np.testing.assert_allclose(T, env.transfer_unoccluded(N), rtol=1e-6, atol=1e-6)  # nothing above a lone triangle
    nv = np.float32([0.3, 0.71])
    want = env.specular_occlusion(nv.astype(np.float64), 0.2, np.array([0.25, 0.1]))
    np.testing.assert_allclose(env.specular_occlusion(nv, 0.2, np.array([0.25, 0.1])), want, rtol=1e-14, atol=0)
