"""The light past an open mesh border in d'Eon's incremental blur chain (issue 30 item 5), plain numpy:
the twin of shaders/lib/open_border.glsl.

Seed 000 eq. 24 blurs incrementally, blur_i = G(v_i - v_(i-1)) * blur_(i-1), and that is eq. 21's
blur_i = G(v_i) * (E 1_S) only if blur_(i-1) is known everywhere, *past* the surface's open border
too: the light step i - 1 carried past the border comes back under step i. A texture holds nothing
there (a UV gutter is a few texels; a red step's taps reach 7 mm), and reading "no light" past the
border before every step drops that light again and again: the uniformly lit 24 mm slab kept 0.928
of its red power against the open square's 0.942, and 0.46 / 0.74 of the lit level at 0 / 0.5 mm
from the rim against 0.50 / 0.79.

What stands past the border instead is the odd reflection of blur_(i-1) about its value at the
border. Across a straight border s = 0 (s the distance into the surface) of a region lit by E,
blur_(i-1)(s) = E Phi(s / sigma), and Phi(-d / sigma) = 1 - Phi(d / sigma), so

    blur_(i-1)(-d) = 2 blur_(i-1)(0) - blur_(i-1)(d) = E - blur_(i-1)(d),      blur_(i-1)(0) = E / 2,

exactly, for every sigma, and for a product E Phi(x / sigma) Phi(y / sigma) (the separable passes at
a corner) along each pass's axis. The border's value is taken as E / 2 from the irradiance map itself
(a sampled blur_(i-1) cannot give it when its sigma is under a texel), and the reflected value is kept
within [0, E / 2] (no light from nowhere where the light under the border is not uniform). The first
step blurs E 1_S itself: nothing past the border, as before.
"""
from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike


def past_border_light(e_border: np.ndarray, mirror: np.ndarray) -> np.ndarray:
    """blur_(i-1) at a point d past the border: E - blur_(i-1)(d), where ``e_border`` is E at the
    point's foot on the border and ``mirror`` blur_(i-1) at d inside it; clamped to [0, E / 2]."""
    half = 0.5 * np.maximum(np.asarray(e_border, np.float64), 0.0)
    return np.clip(2.0 * half - np.asarray(mirror, np.float64), 0.0, half)


def chain_on_segment(E: np.ndarray, dx: float, variances: ArrayLike, inside: np.ndarray, reflect: bool = True) -> np.ndarray:
    """The incremental chain (eq. 24) on a 1D line of samples ``dx`` mm apart, ``inside`` a contiguous
    run (the surface), E the light on it: blur_i for every variance, (len(variances), len(E)). Past
    the run's two ends: nothing before the first step; before every later step the odd reflection
    (``reflect``) or nothing (what the blurs did before). The direct eq. 21 blur G(v_i) * (E 1_S) is
    what it should give."""
    from scipy.ndimage import gaussian_filter1d
    idx = np.flatnonzero(inside)
    lo, hi = int(idx[0]), int(idx[-1])
    x = np.arange(len(E), dtype=np.float64)
    c_lo, c_hi = lo - 0.5, hi + 0.5  # the border lies half a sample past the last sample inside
    Ein = np.where(inside, E, 0.0)
    B = Ein.astype(np.float64)
    prev, out = 0.0, []  # variances: mm^2, increasing
    for i, v in enumerate(np.asarray(variances, np.float64).ravel().tolist()):
        src = np.where(inside, B, 0.0)
        if reflect and i > 0:
            for c, past, foot in ((c_lo, x < c_lo, lo), (c_hi, x > c_hi, hi)):
                m = 2.0 * c - x[past]
                src[past] = past_border_light(np.full(past.sum(), E[foot]), np.interp(m, x, B))
        sd = np.sqrt(max(v - prev, 0.0)) / dx
        prev = v
        B = gaussian_filter1d(src, sd, mode="constant", truncate=6.0) if sd > 0 else src
        out.append(B.copy())
    return np.array(out)


def rim_share(E: ArrayLike, frame: ArrayLike, seam_b: ArrayLike) -> np.ndarray:
    """The direct gather's input at an open border (shaders/seam_fill.frag, RIM_SHARE; issue 30): the
    gather sums a point per texel with the texel's whole area (physics/surface_gather.py), so an island
    texel the border line crosses would carry light over all of it and put the border at the texel's
    outer edge (the slab's rim texel read 2.5 / 5.0 / 6.9 % bright at 512^2). It carries its share on
    the surface instead, c = 1/2 + s / (2 h), s its centre's distance into the surface and h its half
    extent along the border's normal (texels), as the separable blur's whole-texel taps count it; the
    normalisation keeps the whole area, so the part past the border holds no light. ``frame``: the
    border frame (scene/texels.border_frame: R s, GB the normal, A 1 where known); ``seam_b``: the seam
    map's B (0 on island texels). RGB scaled, A (thickness) kept."""
    out = np.array(E, np.float64)
    f = np.asarray(frame, np.float64)
    h = 0.5 * (np.abs(f[..., 1]) + np.abs(f[..., 2]))
    cut = (np.asarray(seam_b) < 0.5) & (f[..., 3] > 0.5) & (f[..., 0] >= 0.0) & (f[..., 0] < h)
    c = 0.5 + 0.5 * f[..., 0] / np.maximum(h, 1e-30)
    out[cut, :3] *= c[cut, None]
    return out
