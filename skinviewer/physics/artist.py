"""The artist model: a skin's scatter colour and scatter radius per channel, and what they mean for
each technique's own parameters.

The two numbers per channel are Burley's normalized diffusion as Unreal's Burley subsurface profile and
HDRP's diffusion profiles present them (seed 001 eq. 2.84, 2.88):

* **scatter colour** A_c in [0, 1]: the surface albedo -- the profile's total diffuse reflectance
  R_d = 2 pi int r R(r) dr = A (eq. 2.84 integrates to A), which also picks the shape factor s(A);
* **scatter radius** l_c in mm: the (diffuse) mean free path; the profile's scale is d = l / s(A)
  (Christensen's searchlight/dmfp fit, eq. 2.88), its mean radius int r 2 pi r R dr / A = 2.5 d.

The Gaussian techniques (d'Eon's texture-space blurs, Jimenez 2009's screen-space Gaussians, the
pre-integrated tables, Gosselin's mm radii) take a sum of Gaussians with variances shared by the three
channels (seed 000 eq. 20-21). :func:`gaussians` fits one to the Burley profile so that, per channel,

* the total weight is exactly A (colour -> total diffuse reflectance), and
* the mean radius sum_i w_i sqrt(pi v_i / 2) / A is exactly 2.5 d (radius -> width; 2 pi r G(v, r)
  has mean sqrt(pi v / 2)),

and the radial energy distribution -- the cumulative P(r) = 2 pi int_0^r R r' dr' / A, eq. (3.9) --
is matched in least squares over log r. Why not the profile lab's eq. (22) objective
(:func:`skinviewer.physics.fitting.fit_gaussians`): its r-weighted L2 of R puts the weight at the 1/r
peak and loses Burley's e^(-r/3d) tail (6 Gaussians on the default skin keep 73 % of the red energy),
which is the part of the profile an artist sees as the red glow. The variances are a fixed geometric
ladder over the channels' scales, so a uniform change of radius scales every variance by its square
and leaves the weights alone (the fit is exactly scale-covariant), and the fit is a few non-negative
least-squares solves (``scipy.optimize.nnls``, as in the lab): ~1 ms, live under a slider.

:func:`estimate_radius` inverts the mapping (a table's per-channel mean radius -> l) exactly for a
table it made, so a preset goes look -> table -> look without drift.
"""
from __future__ import annotations

import math
from typing import cast

import numpy as np
from numpy.typing import ArrayLike

from skinviewer.physics.arrays import FloatArray
from skinviewer.physics.profiles import burley_cdf, burley_scale, sum_of_gaussians

MEAN_RADIUS_PER_D = 2.5  # int_0^inf r (e^(-r/d) + e^(-r/3d)) / (4 d) dr = (d^2 + 9 d^2) / (4 d)
FIT = "searchlight-dmfp"  # eq. (2.88): the radius is the diffuse mean free path (Unreal, HDRP)
# the variance ladder: sigma from LADDER_LO x the smallest d to LADDER_HI x the largest
LADDER_LO, LADDER_HI = 0.12, 6.0
_HARD = 1e4  # weight of the two equality rows in the constrained least squares


def _vec3(x: ArrayLike, name: str) -> FloatArray:
    a = np.broadcast_to(np.asarray(x, dtype=np.float64), (3,)).copy()
    if not np.all(np.isfinite(a)):
        raise ValueError(f"{name} must be finite")
    out: FloatArray = a
    return out


def shape_distance(color: ArrayLike, radius: ArrayLike) -> FloatArray:
    """d = l / s(A) per channel, mm (eq. 2.88)."""
    A = _vec3(color, "scatter colour")
    l = _vec3(radius, "scatter radius")
    if np.any(A < 0) or np.any(A > 1):
        raise ValueError("scatter colour components must be in [0, 1]")
    if np.any(l <= 0):
        raise ValueError("scatter radius components must be > 0 mm")
    return l / burley_scale(A, FIT)


def burley_profile(r: ArrayLike, color: ArrayLike, radius: ArrayLike) -> FloatArray:
    """R(r) of the look, eq. (2.84): A (e^(-r/d) + e^(-r/3d)) / (8 pi d r), shape np.shape(r) + (3,)."""
    from skinviewer.physics.profiles import burley_normalized
    d = shape_distance(color, radius)
    return _vec3(color, "scatter colour") * burley_normalized(np.asarray(r, dtype=np.float64)[..., None], d)


def variance_ladder(d: FloatArray, k: int) -> FloatArray:
    """k variances (mm^2), sigma geometric from LADDER_LO min(d) to LADDER_HI max(d)."""
    lo, hi = LADDER_LO * float(np.min(d)), LADDER_HI * float(np.max(d))
    return np.geomspace(lo, hi, k) ** 2 if k > 1 else np.array([(MEAN_RADIUS_PER_D * float(np.max(d))) ** 2
                                                                 * 2.0 / math.pi])


def gaussians(color: ArrayLike, radius: ArrayLike, k: int = 6, normalize: bool = True) -> tuple[FloatArray, FloatArray]:
    """The sum of ``k`` Gaussians (shared variances, ascending) for the look: (variances (k,) mm^2,
    weights (k, 3)). Per channel the weights sum to A (``normalize``: to 1, d'Eon's convention where the
    albedo map carries the colour and A only shapes the profile) and the mean radius is 2.5 d."""
    from scipy.optimize import nnls  # here, not at import: scipy costs the viewer's start (issue 34)
    if not (1 <= int(k) <= 64):
        raise ValueError("the number of Gaussians must be between 1 and 64")
    k = int(k)
    A = _vec3(color, "scatter colour")
    d = shape_distance(A, radius)
    v = variance_ladder(d, k)
    mean_r = np.sqrt(math.pi * v / 2.0)  # mean radius of each Gaussian's radial energy 2 pi r G
    W = np.zeros((k, 3))
    for c in range(3):
        # radii relative to this channel's d: the same grid for any scale (scale covariance)
        r = d[c] * np.geomspace(1e-3, 60.0, 240)
        t = np.log(r)
        dt = np.gradient(t)
        sw = np.sqrt(dt)  # quadrature of int (...)^2 dlog r
        target = burley_cdf(r, d[c])  # eq. (3.9), per unit energy
        design = -np.expm1(-(r[:, None] ** 2) / (2.0 * v[None, :]))  # the Gaussians' cumulative energies
        M = np.vstack([sw[:, None] * design, _HARD * np.ones((1, k)), _HARD * mean_r[None, :] / (MEAN_RADIUS_PER_D * d[c])])
        b = np.concatenate([sw * target, [_HARD, _HARD]])
        w, _ = nnls(M, b, maxiter=50 * k)
        # the hard rows hold to ~1e-7; make the energy exact (what the colour promises)
        W[:, c] = w / w.sum() if w.sum() > 0 else np.full(k, 1.0 / k)
    if not normalize:
        W = W * A[None, :]
    return v, W


def table(color: ArrayLike, radius: ArrayLike, k: int = 6, normalize: bool = True) -> list[tuple[float, tuple[float, float, float]]]:
    """:func:`gaussians` as ``deon.gaussians`` rows: (variance, (w_r, w_g, w_b)), rounded to 7
    significant digits so that the JSON of a preset reads back to the same numbers."""
    v, W = gaussians(color, radius, k, normalize)
    return [(float(f"{vi:.7g}"), cast("tuple[float, float, float]", tuple(float(f"{x:.7g}") for x in w)))
            for vi, w in zip(v, W)]


def mean_radius(variances: ArrayLike, weights: ArrayLike) -> FloatArray:
    """Per-channel mean radius (mm) of a Gaussian table's radial energy: sum w sqrt(pi v/2) / sum w."""
    v = np.asarray(variances, dtype=np.float64)
    W = np.asarray(weights, dtype=np.float64).reshape(v.size, 3)
    tot = W.sum(axis=0)
    m = np.sqrt(math.pi * np.maximum(v, 0.0) / 2.0) @ W
    return np.where(tot > 0, m / np.where(tot > 0, tot, 1.0), 0.0)


def energy_radius(variances: ArrayLike, weights: ArrayLike, fraction: float = 0.5) -> FloatArray:
    """Per channel, the radius (mm) inside which ``fraction`` of the table's diffuse energy lies."""
    v = np.asarray(variances, dtype=np.float64)
    W = np.asarray(weights, dtype=np.float64).reshape(v.size, 3)
    r = np.geomspace(1e-4, 1e3, 4000)
    P = -np.expm1(-(r[:, None] ** 2) / (2.0 * np.maximum(v, 1e-30)[None, :])) @ W
    P = P / np.maximum(P[-1:], 1e-30)
    return np.array([r[min(int(np.searchsorted(P[:, c], fraction)), r.size - 1)] for c in range(3)])


def estimate_radius(variances: ArrayLike, weights: ArrayLike, color: ArrayLike) -> FloatArray:
    """The scatter radius (mm) per channel whose look has this table's mean radius: l = s(A) m / 2.5
    (the inverse of :func:`gaussians`; for any other table, the Burley look of the same mean reach)."""
    A = _vec3(color, "scatter colour")
    m = mean_radius(variances, weights)
    return np.maximum(m / MEAN_RADIUS_PER_D, 1e-6) * burley_scale(A, FIT)


def estimate_color(weights: ArrayLike, fallback: ArrayLike) -> FloatArray:
    """A table's total diffuse reflectance per channel (sum of weights), as a scatter colour; a
    normalised table (every channel ~1: the colour is in the albedo map) gives ``fallback``."""
    tot = np.asarray(weights, dtype=np.float64).reshape(-1, 3).sum(axis=0)
    if np.all(np.abs(tot - 1.0) < 1e-3):
        return _vec3(fallback, "scatter colour")
    out: FloatArray = np.clip(tot, 0.0, 1.0)
    return out


def cdf_error(color: ArrayLike, radius: ArrayLike, k: int = 6) -> FloatArray:
    """Max |P_fit(r) - P_burley(r)| per channel over r: how well the table follows the look's radial
    energy (eq. 3.9)."""
    v, W = gaussians(color, radius, k, normalize=True)
    d = shape_distance(color, radius)
    r = np.geomspace(1e-3 * float(np.min(d)), 60.0 * float(np.max(d)), 2000)
    P = -np.expm1(-(r[:, None] ** 2) / (2.0 * v[None, :])) @ W
    out: FloatArray = np.max(np.abs(P - burley_cdf(r[:, None], d[None, :])), axis=0)
    return out


def profile_of_table(r: ArrayLike, variances: ArrayLike, weights: ArrayLike) -> FloatArray:
    """R(r) of a table (eq. 21), for plots beside :func:`burley_profile`."""
    return sum_of_gaussians(np.asarray(r, np.float64), np.asarray(variances, np.float64),
                            np.asarray(weights, np.float64).reshape(-1, 3))
