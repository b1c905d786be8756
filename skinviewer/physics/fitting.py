"""Fit a sum of Gaussians to a diffusion profile (seed 000 eq. 20-22, seed 002 section 14.4.5).

Minimises, per channel c, int_0^inf r (R_c(r) - sum_i w_ic G(v_i, r))^2 dr   (seed 000 eq. 22)
and reports the error of seed 001 eq. (3.1) (seed 002 14.4.5):
    E_c = sqrt(int r (R_c - G_sum,c)^2 dr) / sqrt(int r R_c^2 dr)
(the printed denominator lacks the "dr"; it is the same r-weighted integral).

Method (variable projection): the variances are the only nonlinear unknowns. For fixed variances the
best non-negative weights are a linear least-squares problem with w >= 0, solved exactly by
``scipy.optimize.nnls`` on a fixed quadrature grid. The outer problem minimises sum_c E_c^2 over the
log-variances with L-BFGS-B; its gradient is exact by the envelope theorem,
    d/d(log v_i) ||A w - b||^2 = 2 w_i (A w - b) . dA_i/d(log v_i),  dG/d(log v) = G (r^2/(2v) - 1),
from several deterministic starts (log-spaced spreads over the profile's own length scales, plus an
optional warm start such as the previous slider position). Variances are reported ascending.
``shared=True`` (default, what a d'Eon preset needs: seed 000 Tabela 2 shares variances across RGB)
fits one set of variances for the three channels; ``shared=False`` fits each channel on its own.
"""
from __future__ import annotations

import math
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import numpy.typing as npt

from skinviewer.physics.arrays import FloatArray
from skinviewer.physics.profiles import sum_of_gaussians

TWO_PI = 2.0 * math.pi


# ---------------------------------------------------------------------------------------------
# quadrature grid

@dataclass(frozen=True)
class FitGrid:
    """Samples of the target and quadrature weights q with sum_j q_j f(r_j)^2 ~ int_0^inf r f(r)^2 dr."""
    r: FloatArray  # (n,) mm, ascending, > 0
    q: FloatArray  # (n,) quadrature weights (mm^2)
    target: FloatArray  # (n, 3) R(r_j) per channel, 1/mm^2
    total: FloatArray  # (3,) total diffuse reflectance R_d = 2 pi int r R dr of the target

    @property
    def norms(self) -> FloatArray:
        """sqrt(int r R_c^2 dr) per channel: the denominator of eq. (3.1)."""
        return np.sqrt(self.q @ (self.target**2))

    def error(self, fitted: FloatArray) -> FloatArray:
        """Eq. (3.1) per channel for fitted values on this grid (n, 3); 0 where the target is 0."""
        num = np.sqrt(self.q @ ((self.target - fitted) ** 2))
        den = self.norms
        with np.errstate(invalid="ignore", divide="ignore"):
            return np.where(den > 0, num / den, 0.0)

    @classmethod
    def from_samples(cls, r: npt.ArrayLike, R: npt.ArrayLike) -> FitGrid:
        """A grid from tabulated (e.g. measured) samples: r ascending (mm), R (n,) or (n, 3);
        trapezoid weights of int r f^2 dr over [r_0, r_n-1] (plus [0, r_0] at the first value)."""
        r = np.asarray(r, dtype=np.float64)
        R = np.asarray(R, dtype=np.float64)
        if R.ndim == 1:
            R = np.repeat(R[:, None], 3, axis=1)
        if r.ndim != 1 or r.size < 2 or R.shape != (r.size, 3):
            raise ValueError("need at least 2 radii and R of shape (n,) or (n, 3)")
        if np.any(np.diff(r) <= 0) or r[0] < 0 or not np.all(np.isfinite(R)):
            raise ValueError("radii must be ascending and >= 0, values finite")
        dr = np.diff(r)
        q = np.zeros_like(r)
        q[:-1] += 0.5 * dr * r[:-1]
        q[1:] += 0.5 * dr * r[1:]
        q[0] += 0.5 * r[0] ** 2
        total = TWO_PI * np.trapezoid(r[:, None] * R, r, axis=0)
        keep = r > 0
        return cls(r[keep], q[keep], R[keep], total)


def make_grid(profile: Callable[[FloatArray], FloatArray], n: int = 200, r_min: float | None = None,
              r_max: float | None = None, rel: float = 1e-10) -> FitGrid:
    """A log-spaced grid covering where the integrand of eq. (3.1), r R(r)^2, matters.

    The range is found from a probe of r R^2 over 1e-5..1e4 mm (or ``profile.probe_range()``): all but a fraction ``rel`` of
    int r R_c^2 dr (every channel) lies inside. ``r_min`` overrides the lower end (needed for Burley,
    whose r R^2 ~ 1/r is not integrable at 0: its ``min_fit_radius`` is used when present).
    Quadrature: trapezoid in t = log r of r^2 f^2, plus r_0^2/2 f(r_0)^2 for [0, r_0].
    """
    p_lo, p_hi = profile.probe_range() if hasattr(profile, "probe_range") else (1e-5, 1e4)
    probe = np.geomspace(p_lo, p_hi, int(40 * math.log10(p_hi / p_lo)) + 1)
    Rp = _rgb_values(profile(probe))
    if r_min is None and hasattr(profile, "min_fit_radius"):
        r_min = float(profile.min_fit_radius())
    dens = probe[:, None] ** 2 * Rp**2  # r R^2 dr = r^2 R^2 dlog r
    lo_i, hi_i = 0, probe.size - 1
    tot = dens.sum(axis=0)
    live = tot > 0
    if np.any(live):
        cum = np.cumsum(dens[:, live], axis=0) / tot[live]
        lo_i = int(max(0, np.min(np.argmax(cum >= rel, axis=0)) - 1))
        hi_i = int(min(probe.size - 1, np.max(np.argmax(cum >= 1.0 - rel, axis=0)) + 1))
    lo = probe[lo_i] if r_min is None else r_min
    hi = probe[hi_i] if r_max is None else r_max
    if not (0 < lo < hi):
        raise ValueError("empty fitting range")
    r = np.geomspace(lo, hi, n)
    R = _rgb_values(profile(r))
    t = np.log(r)
    q = np.zeros(n)
    dt = np.diff(t)
    q[:-1] += 0.5 * dt * r[:-1] ** 2
    q[1:] += 0.5 * dt * r[1:] ** 2
    q[0] += 0.5 * r[0] ** 2
    if hasattr(profile, "total_reflectance"):
        total = np.asarray(profile.total_reflectance(), dtype=np.float64)
    else:
        total = TWO_PI * np.asarray(np.trapezoid(probe[:, None] ** 2 * Rp, np.log(probe), axis=0))
    return FitGrid(r, q, R, total)


def _rgb_values(R: FloatArray) -> FloatArray:
    R = np.asarray(R, dtype=np.float64)
    if R.ndim == 1:
        R = np.repeat(R[:, None], 3, axis=1)
    if not np.all(np.isfinite(R)):
        raise ValueError("the profile has non-finite values on the fitting grid")
    return R


# ---------------------------------------------------------------------------------------------
# result

@dataclass
class FitResult:
    """Gaussians fitted to a profile. Shared: variances (k,), weights (k, 3). Per channel:
    variances (3, k), weights (3, k) (row c is channel c)."""
    variances: FloatArray
    weights: FloatArray
    errors: FloatArray  # (3,) eq. (3.1)
    shared: bool
    target_total: FloatArray  # (3,) R_d of the target profile
    grid: FitGrid = field(repr=False)
    seconds: float = 0.0
    evaluations: int = 0

    @property
    def k(self) -> int:
        return int(self.variances.shape[-1])

    def __call__(self, r: FloatArray) -> FloatArray:
        return sum_of_gaussians(r, self.variances, self.weights)

    @property
    def fitted_total(self) -> FloatArray:
        """R_d of the Gaussian sum = sum of weights per channel (each G integrates to 1)."""
        out: FloatArray = self.weights.sum(axis=0) if self.shared else self.weights.sum(axis=1)
        return out

    def table(self, normalize: bool = False) -> list[tuple[float, tuple[float, float, float]]]:
        """(variance, (w_r, w_g, w_b)) rows, ascending variance, as in seed 000 Tabela 2. Per-channel
        fits become one row per (channel, Gaussian) with zero weight in the other channels.
        ``normalize``: each channel's weights scaled to sum 1 (d'Eon's convention: R_d is in the albedo)."""
        if self.shared:
            rows = [(float(v), w.astype(float)) for v, w in zip(self.variances, self.weights)]
        else:
            rows = []
            for c in range(3):
                for v, w in zip(self.variances[c], self.weights[c]):
                    ww = np.zeros(3)
                    ww[c] = w
                    rows.append((float(v), ww))
            rows.sort(key=lambda t: t[0])
        if normalize:
            tot = np.sum([w for _, w in rows], axis=0)
            scale = np.where(tot > 0, 1.0 / np.where(tot > 0, tot, 1.0), 0.0)
            rows = [(v, w * scale) for v, w in rows]
        return [(v, (float(w[0]), float(w[1]), float(w[2]))) for v, w in rows]

    def to_dict(self) -> dict[str, Any]:
        ch = {}
        for c, name in enumerate("rgb"):
            v = self.variances if self.shared else self.variances[c]
            w = self.weights[:, c] if self.shared else self.weights[c]
            ch[name] = {"variances": [float(x) for x in v], "weights": [float(x) for x in w],
                        "error": float(self.errors[c]), "fitted_total": float(self.fitted_total[c]),
                        "target_total": float(self.target_total[c])}
        return {"k": self.k, "shared_variances": self.shared, "channels": ch,
                "seconds": self.seconds, "evaluations": self.evaluations}


# ---------------------------------------------------------------------------------------------
# the variable-projection core

class _Problem:
    def __init__(self, grid: FitGrid, channels: Sequence[int]):
        self.r2 = grid.r**2
        self.sw = np.sqrt(grid.q)
        norms = grid.norms[list(channels)]
        self.scale = np.where(norms > 0, norms, 1.0)
        self.live = norms > 0
        self.B = (self.sw[:, None] * grid.target[:, list(channels)]) / self.scale  # unit-norm targets
        self.nfev = 0

    def design(self, theta: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray]:
        v = np.exp(theta)
        with np.errstate(under="ignore"):
            G = np.exp(-self.r2[:, None] / (2.0 * v)) / (TWO_PI * v)
        A = self.sw[:, None] * G
        cn = np.sqrt((A * A).sum(axis=0))  # elementwise, not BLAS: tiny matrices, no thread start-up
        cn = np.where(cn > 0, cn, 1.0)
        return v, A, cn

    def solve(self, theta: FloatArray) -> tuple[float, FloatArray, FloatArray]:
        """Objective sum_c E_c^2, its gradient in theta, weights (k, m) for the unit-norm targets."""
        from scipy.optimize import nnls  # here, not at import: scipy costs the viewer's start (issue 34)
        self.nfev += 1
        v, A, cn = self.design(theta)
        An = A / cn
        W = np.zeros((theta.size, self.B.shape[1]))
        f = 0.0
        grad = np.zeros(theta.size)
        dA = A * (self.r2[:, None] / (2.0 * v) - 1.0)
        for c in range(self.B.shape[1]):
            if not self.live[c]:
                continue
            wn, _ = nnls(An, self.B[:, c], maxiter=50 * theta.size)
            w = wn / cn
            res = (A * w).sum(axis=1) - self.B[:, c]
            f += float((res * res).sum())
            grad += 2.0 * w * (res[:, None] * dA).sum(axis=0)
            W[:, c] = w
        return f, grad, W


def _starts(grid: FitGrid, k: int, lo: float, hi: float, init: FloatArray | None) -> list[FloatArray]:
    """Deterministic log-variance starts from the profile's scales (5 %..95 % of int r R^2 dr)."""
    dens = grid.q[:, None] * grid.target**2
    tot = dens.sum(axis=0)
    live = tot > 0
    if np.any(live):
        cum = np.cumsum(dens[:, live], axis=0) / tot[live]
        ra = grid.r[min(np.argmax(cum >= 0.05, axis=0))]
        rb = grid.r[max(np.argmax(cum >= 0.95, axis=0))]
    else:
        ra, rb = grid.r[0], grid.r[-1]
    a, b = 2.0 * math.log(ra) - 1.0, 2.0 * math.log(rb) + 1.0
    span = max(b - a, 1.0)
    spreads = [(a, b), (a - 0.25 * span, b + 0.25 * span), (a + 0.2 * span, b - 0.2 * span),
               (a - 0.3 * span, b - 0.1 * span), (a + 0.1 * span, b + 0.3 * span)]
    out = []
    if init is not None:
        out.append(_pad_init(np.log(np.asarray(init, dtype=np.float64)), k, a, b))
    for s, e in spreads:
        out.append(np.linspace(s, e, k) if k > 1 else np.array([0.5 * (s + e)]))
    return [np.clip(np.sort(x), lo, hi) for x in out]


def _pad_init(theta: FloatArray, k: int, a: float, b: float) -> FloatArray:
    theta = np.sort(theta[np.isfinite(theta)])
    while theta.size > k:  # merge the closest pair
        i = int(np.argmin(np.diff(theta)))
        theta = np.concatenate([theta[:i], [0.5 * (theta[i] + theta[i + 1])], theta[i + 2:]])
    while theta.size < k:  # split the widest gap (or extend the range)
        ext = np.concatenate([[a], theta, [b]]) if theta.size else np.array([a, b])
        i = int(np.argmax(np.diff(ext)))
        theta = np.sort(np.concatenate([theta, [0.5 * (ext[i] + ext[i + 1])]]))
    return theta


def _fit_channels(grid: FitGrid, channels: Sequence[int], k: int, fixed: np.ndarray | None,
                  init: np.ndarray | None, max_starts: int) -> Any:
    from scipy.optimize import minimize  # here, not at import: scipy costs the viewer's start (issue 34)
    prob = _Problem(grid, channels)
    lo = 2.0 * math.log(grid.r[0]) - math.log(16.0)
    hi = 2.0 * math.log(grid.r[-1]) + math.log(4.0)
    if fixed is not None:
        theta = np.log(fixed)
        _, _, W = prob.solve(theta)
        return fixed.copy(), W * prob.scale, prob.nfev
    best = None
    fun = lambda th: prob.solve(th)[:2]
    for x0 in _starts(grid, k, lo, hi, init)[:max_starts]:
        res = minimize(fun, x0, jac=True, method="L-BFGS-B", bounds=[(lo, hi)] * k,
                       options={"maxiter": 400, "ftol": 1e-13, "gtol": 1e-10})
        if best is None or res.fun < best.fun:
            best = res
    assert best is not None, "max_starts >= 1"
    theta = np.sort(best.x)
    _, _, W = prob.solve(theta)
    return np.exp(theta), W * prob.scale, prob.nfev


def fit_gaussians(profile: Callable[[FloatArray], FloatArray] | FitGrid, k: int = 4, *, shared: bool = True,
                  fixed_variances: npt.ArrayLike | None = None, init: Sequence[float] | None = None,
                  grid_points: int = 200, max_starts: int = 6) -> FitResult:
    """Fit ``k`` Gaussians (weights >= 0, variances ascending) to ``profile`` (a callable r -> (..., 3),
    e.g. a model from :mod:`skinviewer.physics.profiles`, or a prepared :class:`FitGrid`).

    ``fixed_variances``: only the weights are fitted (non-negative linear least squares).
    ``init``: warm-start variances (e.g. the previous fit while a slider moves); any length.
    """
    t0 = time.perf_counter()
    grid = profile if isinstance(profile, FitGrid) else make_grid(profile, n=grid_points)
    fixed = None
    if fixed_variances is not None:
        fixed = np.sort(np.asarray(fixed_variances, dtype=np.float64))
        if fixed.ndim != 1 or fixed.size < 1 or np.any(~np.isfinite(fixed)) or np.any(fixed <= 0):
            raise ValueError("fixed variances must be positive numbers")
        k = fixed.size
    if not (1 <= int(k) <= 64):
        raise ValueError("the number of Gaussians must be between 1 and 64")
    k = int(k)
    nfev = 0
    if shared:
        v, W, nfev = _fit_channels(grid, (0, 1, 2), k, fixed, None if init is None else np.asarray(init),
                                   max_starts)
        variances, weights = v, W  # (k,), (k, 3)
    else:
        variances = np.zeros((3, k))
        weights = np.zeros((3, k))
        for c in range(3):
            ic = None
            if init is not None:
                a = np.asarray(init, dtype=np.float64)
                ic = a[c] if a.ndim == 2 else a
            v, W, n = _fit_channels(grid, (c,), k, fixed, ic, max_starts)
            variances[c], weights[c] = v, W[:, 0]
            nfev += n
    fitted = sum_of_gaussians(grid.r, variances, weights)
    res = FitResult(variances, weights, grid.error(fitted), shared, grid.total, grid,
                    time.perf_counter() - t0, nfev)
    return res


def fit_error(profile_values: FloatArray, fitted_values: FloatArray, r: FloatArray) -> FloatArray:
    """Eq. (3.1) for tabulated values on ascending radii (trapezoid in r): per channel (last axis)."""
    g = FitGrid.from_samples(r, profile_values)
    f = np.asarray(fitted_values, dtype=np.float64)
    if f.ndim == 1:
        f = np.repeat(f[:, None], 3, axis=1)
    keep = np.asarray(r) > 0
    return g.error(f[keep])
