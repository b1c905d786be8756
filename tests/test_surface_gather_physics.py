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
