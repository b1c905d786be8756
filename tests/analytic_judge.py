"""Analytic judges for the tests and ``benchmarks/bench_accuracy.py`` (plain numpy, no GL): how far a
rendered texture-space result is from what the technique should produce.

Not part of the package (it was ``skinviewer/physics/accuracy.py``, used only by tests and benchmarks):
what it answers for a user -- how close a technique comes on the laser -- the product answers with
``skinviewer bench --scene laser`` against the brute-force ground truth; here it stays the tests'
closed-form oracle.

Laser (GPU Gems 3 §14.4.1): a beam lights a few texels of a flat slab; the diffuse result D (d'Eon:
sum_i w_i blur_i, Gosselin: the blurred light map), divided by the beam's power, is compared with the
*analytic* profile sum_i w_i G(v_i, r) convolved with the irradiance texels actually lit (the method
of tests/test_deon.py), so a beam narrower than a texel, or lighting several texels, costs no error.
Two metrics per channel:

* ``l1``: the r-weighted relative L1 error of the radial averages (bins of 0.05 mm up to ``rmax``),
  sum r |m - f| / sum r f -- the figure tests/test_deon.py asserts on. Angular ripples average out.
* ``eq31``: seed 001 eq. (3.1), sqrt(int r (R - G)^2 dr) / sqrt(int r R^2 dr), evaluated over the
  plane: for a radial function int r f^2 dr = (1 / 2 pi) int f^2 dA, so the ratio is
  sqrt(sum (D - ref)^2) / sqrt(sum ref^2) over the texels within ``rmax`` (texels have equal area).
  Nothing is averaged away: anisotropy (stretch off) and tap ripples count. Peak-sensitive.

Shadow edge (Gosselin): a hard, straight shadow edge blurred by ``n`` Poisson iterations. Along the
row across the edge the 2D blur acts through its x-marginal, which for the 13-tap kernel (centre +
POISSON_12 * R, bilinear taps) is the exact 1D kernel of :func:`poisson_kernel_1d`. The blurred edge
is compared with an erf edge of the same variance, Phi((x - x0) / sigma), sigma^2 = n * var(kernel).

Units: mm for the laser, texels for the edge helpers (the caller scales).
"""
from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
from scipy.special import ndtr

from skinviewer.physics.diffusion import blur_plan, gaussian, profile_variance, sub_steps  # noqa: F401
from skinviewer.physics.poisson import POISSON_12

# ---------------------------------------------------------------------------------------------
# planar scenes: texel centres in millimetres


def _linear_uv_map(positions, uvs, mm_per_unit: float, mask=None):
    P = np.asarray(positions, dtype=np.float64)
    UV = np.asarray(uvs, dtype=np.float64)
    if mask is not None:
        P, UV = P[mask], UV[mask]
    ax = np.polyfit(UV[:, 0], P[:, 0], 1) * mm_per_unit
    ay = np.polyfit(UV[:, 1], P[:, 1], 1) * mm_per_unit
    return ax, ay


def plane_coords(positions, uvs, mm_per_unit: float, n: int, mask=None):
    """(X, Y, texel_area): texel centres of an n x n texture in mm for a plane whose UVs are a linear
    map of x and y (the laser / stretch-plane / shadow-edge planes; ``mask`` selects its vertices)."""
    ax, ay = _linear_uv_map(positions, uvs, mm_per_unit, mask)
    c = (np.arange(n) + 0.5) / n
    X = np.broadcast_to(np.polyval(ax, c)[None, :], (n, n))
    Y = np.broadcast_to(np.polyval(ay, c)[:, None], (n, n))
    return X, Y, abs(ax[0] * ay[0]) / n ** 2


def texel_mm(positions, uvs, mm_per_unit: float, n: int, mask=None) -> tuple[float, float]:
    """Texel size (mm) along u and v of an n x n texture on such a plane."""
    ax, ay = _linear_uv_map(positions, uvs, mm_per_unit, mask)
    return abs(ax[0]) / n, abs(ay[0]) / n


# ---------------------------------------------------------------------------------------------
# laser profile


def profile_reference(E, X, Y, area, variances, weights, rmax: float | None = None):
    """The analytic profile sum_i w_i G(v_i, r) convolved with the lit texels of the irradiance E
    (n, n, >=3), divided by the beam's power. Returns (ref (n, n, 3), power (3,), (cx, cy)): power =
    sum E * texel area per channel; (cx, cy) the red power centroid (mm). ``rmax``: evaluate only
    within rmax of the centroid (0 elsewhere; saves time on large textures)."""
    E = np.asarray(E, dtype=np.float64)[..., :3]
    lit = np.any(E > 0, axis=-1)
    if not lit.any():
        raise ValueError("no irradiance texel is lit (beam narrower than a texel?)")
    pw = E[lit] * area
    tot = pw.sum(0)
    w0 = pw[:, 0] if tot[0] > 0 else pw.sum(1)
    cx, cy = float(w0 @ X[lit] / w0.sum()), float(w0 @ Y[lit] / w0.sum())
    var = np.asarray(variances, dtype=np.float64)
    w = np.asarray(weights, dtype=np.float64).reshape(len(var), 3)
    keep = np.ones(X.shape, bool) if rmax is None else np.hypot(X - cx, Y - cy) <= rmax + 1e-9
    xs, ys = X[keep], Y[keep]
    acc = np.zeros((xs.size, 3))
    for x0, y0, p in zip(X[lit], Y[lit], pw):
        rr = np.hypot(xs - x0, ys - y0)
        for v, wi in zip(var, w):
            acc += gaussian(v, rr)[:, None] * (p * wi)
    ref = np.zeros(X.shape + (3,))
    with np.errstate(invalid="ignore", divide="ignore"):
        ref[keep] = acc / np.where(tot > 0, tot, 1.0)
    return ref, tot, (cx, cy)


def radial_means(values, R, rmax: float = 10.0, bins: int = 200):
    """Radial averages of values (..., C) in ``bins`` rings up to rmax: (ring centres (k,), (k, C)),
    rings without a texel left out."""
    values = np.asarray(values, dtype=np.float64)
    C = values.shape[-1]
    edges = np.linspace(0.0, rmax, bins + 1)
    idx = np.digitize(np.asarray(R).ravel(), edges) - 1
    ok = (idx >= 0) & (idx < bins)
    cnt = np.bincount(idx[ok], None, bins)
    has = cnt > 0
    rc = 0.5 * (edges[1:] + edges[:-1])
    out = np.stack([np.bincount(idx[ok], values[..., c].ravel()[ok], bins)[has] / cnt[has] for c in range(C)], -1)
    return rc[has], out


def l1_radial_error(D, ref, R, rmax: float = 10.0, bins: int = 200) -> np.ndarray:
    """sum r |m - f| / sum r f per channel over radial averages (tests/test_deon.py's metric)."""
    rc, m = radial_means(D, R, rmax, bins)
    _, f = radial_means(ref, R, rmax, bins)
    den = np.sum(rc[:, None] * f, axis=0)
    num = np.sum(rc[:, None] * np.abs(m - f), axis=0)
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(den > 0, num / den, np.nan)


def eq31_error(D, ref, R=None, rmax: float | None = None) -> np.ndarray:
    """Seed 001 eq. (3.1) per channel over the plane: sqrt(sum (D - ref)^2) / sqrt(sum ref^2) over
    equal-area texels (within rmax of the centre when R and rmax are given)."""
    D = np.asarray(D, dtype=np.float64)[..., :3]
    ref = np.asarray(ref, dtype=np.float64)[..., :3]
    m = np.ones(D.shape[:-1], bool) if R is None or rmax is None else np.asarray(R) <= rmax
    num = np.sqrt(np.sum((D[m] - ref[m]) ** 2, axis=0))
    den = np.sqrt(np.sum(ref[m] ** 2, axis=0))
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(den > 0, num / den, np.nan)


def laser_errors(D, E, X, Y, area, variances, weights, rmax: float = 10.0, bins: int = 200) -> dict:
    """Both metrics of a diffuse result D (n, n, >=3) lit by the irradiance E against the analytic
    profile (variances, weights (k, 3)). Also: ``power`` (beam power per channel), ``kept`` (power in
    D / (power * sum of the reference weights), i.e. 1 = energy conserved)."""
    ref, tot, (cx, cy) = profile_reference(E, X, Y, area, variances, weights, rmax)
    Dn = np.asarray(D, dtype=np.float64)[..., :3] / np.where(tot > 0, tot, 1.0)
    R = np.hypot(X - cx, Y - cy)
    wsum = np.asarray(weights, dtype=np.float64).reshape(-1, 3).sum(0)
    with np.errstate(invalid="ignore", divide="ignore"):
        kept = Dn.sum((0, 1)) * area / np.where(wsum > 0, wsum, np.nan)
    return {"l1": l1_radial_error(Dn, ref, R, rmax, bins), "eq31": eq31_error(Dn, ref, R, rmax),
            "power": tot, "kept": kept, "centre": (cx, cy)}


def deon_blur_passes(variances, reuse_below: float, texel: float) -> list[int]:
    """Separable 7-tap (H+V) blurs the d'Eon chain runs per Gaussian, as GaussianBlurPass splits
    them (diffusion.sub_steps; 0 for a Gaussian that reuses the irradiance)."""
    out = []
    for step in blur_plan(list(variances), reuse_below):
        if step.reused:
            out.append(0)
            continue
        sin = math.sqrt(max(step.variance - step.increment, 0.0))
        out.append(len(sub_steps(sin, step.increment, texel)))
    return out


# ---------------------------------------------------------------------------------------------
# shadow edge, Poisson kernel


def width_10_90(profile) -> float:
    """10-90 % width (samples) of a monotone-ish rising edge, linear interpolation between samples."""
    p = np.asarray(profile, np.float64)
    lo, hi = p.min(), p.max()
    t = (p - lo) / max(hi - lo, 1e-12)

    def cross(level):
        k = int(np.argmax(t >= level))
        if k == 0:
            return 0.0
        a, b = t[k - 1], t[k]
        return k - 1 + (level - a) / max(b - a, 1e-12)

    return cross(0.9) - cross(0.1)


GAUSS_10_90 = 2.0 * 1.2815515655446004  # 10-90 % width of an erf edge, in sigmas


def poisson_kernel_1d(radius: float, taps: Sequence[Sequence[float]] = POISSON_12):
    """The x-marginal of one Poisson iteration (eq. 13: centre + 12 taps at p_i * R, weights 1/13)
    as sampled on the texel grid, bilinear taps included: (offsets (m,) int, weights (m,))."""
    n = len(taps) + 1
    d = np.concatenate([[0.0], np.asarray(taps, dtype=np.float64)[:, 0] * float(radius)])
    k0 = np.floor(d).astype(np.int64)
    f = d - k0
    lo = int(k0.min())
    w = np.zeros(int(k0.max()) + 2 - lo)
    np.add.at(w, k0 - lo, (1.0 - f) / n)
    np.add.at(w, k0 + 1 - lo, f / n)
    return np.arange(lo, lo + w.size), w


def iterate_kernel(offsets, weights, n: int):
    """The kernel convolved with itself n times (n = 0: the identity)."""
    offs, w = np.array([0]), np.array([1.0])
    for _ in range(int(n)):
        w = np.convolve(w, weights)
        offs = np.arange(offs[0] + offsets[0], offs[0] + offsets[0] + w.size)
    return offs, w


def kernel_variance(offsets, weights) -> float:
    o = np.asarray(offsets, np.float64)
    w = np.asarray(weights, np.float64)
    m = float(w @ o) / w.sum()
    return float(w @ (o - m) ** 2) / w.sum()


def poisson_variance(radius: float, taps=POISSON_12) -> float:
    """Per-axis (x) variance, texels^2, of one Poisson iteration of radius R texels."""
    return kernel_variance(*poisson_kernel_1d(radius, taps))


def apply_kernel_1d(row, offsets, weights):
    """Gather row[j + o] * w (edge samples clamped), like the shader's CLAMP_TO_EDGE taps."""
    row = np.asarray(row, np.float64)
    j = np.arange(row.size)
    out = np.zeros(row.size)
    for o, w in zip(offsets, weights):
        out += w * row[np.clip(j + o, 0, row.size - 1)]
    return out


def edge_position(t) -> float:
    """Sub-sample position of the 50 % crossing of a rising edge t (normalised 0..1)."""
    t = np.asarray(t, np.float64)
    k = int(np.argmax(t >= 0.5))
    if k == 0:
        return 0.0
    a, b = t[k - 1], t[k]
    return k - 1 + (0.5 - a) / max(b - a, 1e-12)


def erf_edge(x, x0: float, sigma: float):
    """Phi((x - x0) / sigma): a step at x0 blurred by a Gaussian of standard deviation sigma."""
    x = np.asarray(x, np.float64)
    if sigma <= 0:
        return np.where(x > x0, 1.0, np.where(x < x0, 0.0, 0.5))
    return ndtr((x - x0) / sigma)


def fit_erf_sigma(x, t, x0: float) -> float:
    """Least-squares sigma of an erf edge at x0 to the normalised edge t (golden-section on log sigma)."""
    x = np.asarray(x, np.float64)
    t = np.asarray(t, np.float64)

    def cost(ls):
        return float(np.sum((erf_edge(x, x0, math.exp(ls)) - t) ** 2))

    a, b = math.log(1e-3), math.log(max(np.ptp(x), 1.0))
    g = (math.sqrt(5) - 1) / 2
    c, d = b - g * (b - a), a + g * (b - a)
    for _ in range(80):
        if cost(c) < cost(d):
            b = d
        else:
            a = c
        c, d = b - g * (b - a), a + g * (b - a)
    return math.exp(0.5 * (a + b))

