"""physics/surface_gather.gather_blocks (the twin of deon_gather_blocks.frag) against a texel-by-texel
reference written from its docstring (issue 36: the mutation sample of surface_gather.py found its block
sums checked only through the whole gather's image)."""
from __future__ import annotations

import numpy as np

from skinviewer.physics.surface_gather import PAST_BORDER_SHARE, gather_blocks


def _reference(E, S, Z):
    """Per 2 x 2 block, one texel at a time: area = sum |a|, the area's mean point and per-axis spread
    (half the trace of the area-weighted covariance), E A summed (RGB halved past a border, a < 0), the
    light's mean point and spread (weights |a| (E.r + E.g + E.b); the area's where there is no light),
    and the zone when every surface texel of the block shares one (else 0)."""
    n = E.shape[0]
    h = n // 2
    out = {k: np.zeros((h, h) + s) for k, s in (("light", (4,)), ("point", (3,)), ("area", ()), ("spread", ()),
                                                 ("lit_point", (3,)), ("lit_spread", ()), ("zone", ()))}
    for bj in range(h):
        for bi in range(h):
            ts = [(2 * bj + dj, 2 * bi + di) for dj in (0, 1) for di in (0, 1)]
            a = np.array([abs(S[t][3]) for t in ts])
            p = np.array([S[t][:3] for t in ts])
            L = np.array([E[t] * np.r_[[PAST_BORDER_SHARE if S[t][3] < 0 else 1.0] * 3, 1.0] for t in ts])
            area = a.sum()
            point = (a[:, None] * p).sum(0) / area
            spread = 0.5 * (a * ((p - point) ** 2).sum(1)).sum() / area
            lw = a * L[:, :3].sum(1)
            if lw.sum() > 0:
                lp = (lw[:, None] * p).sum(0) / lw.sum()
                ls = 0.5 * (lw * ((p - lp) ** 2).sum(1)).sum() / lw.sum()
            else:
                lp, ls = point, spread
            zones = {Z[t] for t, ai in zip(ts, a) if ai > 0}
            for k, val in (("light", (a[:, None] * L).sum(0)), ("point", point), ("area", area), ("spread", spread),
                           ("lit_point", lp), ("lit_spread", ls), ("zone", zones.pop() if len(zones) == 1 else 0.0)):
                out[k][bj, bi] = val
    return out


def test_gather_blocks_texel_by_texel():
    rng = np.random.default_rng(36)
    n = 6
    E = rng.uniform(0.0, 2.0, (n, n, 4))
    E[0:2, 2:4, :3] = 0.0  # a block without light: its light point and spread are the area's
    S = np.zeros((n, n, 4))
    S[..., :3] = rng.normal(0.0, 3.0, (n, n, 3))
    S[..., 3] = rng.uniform(0.2, 1.5, (n, n))
    S[1, 1, 3] *= -1.0  # past a mesh border: area kept, light halved
    S[4, 5, 3] = 0.0  # not surface
    Z = np.ones((n, n))
    Z[2, 2] = 2.0  # a block of two zones: zone 0
    Z[5, 5] = 3.0  # ... unless the other zone's texel is not surface: here (4, 5) is not, (5, 4) is: mixed
    got = gather_blocks(E, S, Z)
    want = _reference(E, S, Z)
    for k in want:
        np.testing.assert_allclose(got[k], want[k], rtol=1e-12, atol=1e-12, err_msg=k)
    assert got["zone"][1, 1] == 0.0 and got["zone"][0, 0] == 1.0


def test_the_gather_on_a_flat_sheet_is_the_brute_force_gaussian_average():
    """On a flat, evenly sampled sheet (1 mm texels, unit area, one zone, no shear) the gather is eq. 21's
    normalised Gaussian average of the light over every texel, E's thickness channel too. Narrow (sigma 0.4
    texel: the 36 nearby texels alone, exact to 5e-7 measured) and wide (sigma 1 and 3 texels: the outer
    2 x 2 blocks moment-matched; measured 2e-3 and 8e-3 off on a light of 0..4), on interior texels."""
    from skinviewer.physics.surface_gather import surface_gather
    n = 32
    yy, xx = np.mgrid[0:n, 0:n].astype(float)
    S = np.zeros((n, n, 4))
    S[..., 0], S[..., 1], S[..., 3] = xx, yy, 1.0
    Z = np.ones((n, n))
    st = np.zeros((n, n, 3))
    st[..., 0] = st[..., 1] = 1.0 / n  # UV per mm: one texel (1 / n of UV) per mm
    rng = np.random.default_rng(1)
    E = np.stack([1 + 0.1 * xx, 1 + 0.05 * yy, rng.uniform(0, 1, (n, n)), 1 + 0.02 * xx], -1)
    P, Ef = S[..., :3].reshape(-1, 3), E.reshape(-1, 4)
    d2 = ((P[:, None] - P[None]) ** 2).sum(-1)
    m = slice(12, 20)
    for sigma, tol in ((0.4, 5e-6), (1.0, 5e-3), (3.0, 2e-2)):
        G = np.exp(-0.5 * d2 / sigma ** 2)
        ref = ((G @ Ef) / G.sum(1)[:, None]).reshape(n, n, 4)
        got = surface_gather(E.astype(np.float32), S, Z, st, sigma ** 2)
        assert np.abs(got - ref)[m, m].max() < tol, (sigma, np.abs(got - ref)[m, m].max())


def test_a_sheared_flat_sheet_keeps_every_texel_on_it():
    """A flat sheet whose texel axes meet at acos(0.9) = 26 deg (P = i u + j w, |u| = |w| = 1 mm): the stretch
    map's shear cosine 0.9 makes the offset along the surface a^2 + b^2 + 2 c a b, exactly the 3-D distance,
    so no texel of the sheet is taken for one across air (the shortcut test) and the gather is again the
    brute-force Gaussian average; the anti-diagonal neighbours are 0.45 mm away, nearer than the
    axis ones. Sigma 1.5 mm: measured 0.025 off on a light of 1..3.4 (the outer 2 x 2 blocks' moment
    matching on so sheared a map), bound 0.05; with the shear's sign flipped, 0.16 (the anti-diagonal
    texels dropped as "across air")."""
    from skinviewer.physics.surface_gather import surface_gather
    n, c = 24, 0.9
    jj, ii = np.mgrid[0:n, 0:n].astype(float)
    S = np.zeros((n, n, 4))
    S[..., 0], S[..., 1], S[..., 3] = ii + c * jj, np.sqrt(1 - c * c) * jj, 1.0
    st = np.zeros((n, n, 3))
    st[..., 0] = st[..., 1] = 1.0 / n
    st[..., 2] = c
    E = np.stack([1 + 0.1 * ii, 1 + 0.05 * jj, (ii + jj) % 3, np.ones((n, n))], -1)
    P, Ef = S[..., :3].reshape(-1, 3), E.reshape(-1, 4)
    G = np.exp(-0.5 * ((P[:, None] - P[None]) ** 2).sum(-1) / 2.25)
    ref = ((G @ Ef) / G.sum(1)[:, None]).reshape(n, n, 4)
    got = surface_gather(E, S, np.ones((n, n)), st, 2.25)
    assert np.abs(got - ref)[8:16, 8:16].max() < 0.05
