"""Pre-integrated skin (Penner & Borshukov, GPU Pro 2, 2011), in plain numpy.

A lit sphere of radius r seen at a point whose normal makes angle theta with the light: the light that
point receives through the skin is the irradiance around a ring of the sphere, weighted by the diffusion
profile R at the chord distance between the two points:

    D(theta, r) = int_{-pi}^{pi} max(cos(theta + x), 0) R(2 r sin(x/2)) dx / int_{-pi}^{pi} R(2 r sin(x/2)) dx

with R(d) = sum_i w_i G(v_i, d) (seed 000 eq. 21) per colour channel. The shader looks D up by
(N.L, curvature 1/r). A shadow edge is widened the same way: a PCF penumbra of world width W is a linear
ramp, and the scattered shadow is that ramp convolved with the profile's 1-D projection
a_p(x) = sum_i w_i exp(-x^2 / 2 v_i) / sqrt(2 pi v_i) (design/screen_space.md §3.3.2), looked up by
(shadow value, W). Curvature per vertex from the mesh: the mean over a vertex's edges of the normal
change per unit length along the edge (a sphere of radius R gives 1/R everywhere).
"""
from __future__ import annotations

import math
from collections.abc import Iterable
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from skinviewer.physics.arrays import FloatArray

N_RING = 257  # ring samples per Gaussian (trapezoid over the Gaussian's own support)


def _gaussian_2d(v: float, d: FloatArray) -> FloatArray:
    return np.exp(-d * d / (2.0 * v)) / (2.0 * math.pi * v)  # G(v, r), seed 000 eq. 21


def _ring_terms(v: float, r: float, cos_theta: FloatArray) -> tuple[FloatArray, float]:
    """For one Gaussian of variance ``v`` (mm^2) on a ring of radius ``r`` (mm): the numerator
    int max(cos(theta + x), 0) G(v, 2 r sin(x/2)) dx per theta, and the denominator int G dx."""
    sigma = math.sqrt(v)
    # the Gaussian's support on the ring: chord <= 7 sigma (beyond it G < 2e-11 of its peak)
    half = math.pi if 3.5 * sigma >= r else 2.0 * math.asin(3.5 * sigma / r)
    x = np.linspace(-half, half, N_RING)
    g = _gaussian_2d(v, 2.0 * r * np.sin(np.abs(x) / 2.0))
    wts = np.full(N_RING, x[1] - x[0])
    wts[0] = wts[-1] = 0.5 * (x[1] - x[0])
    theta = np.arccos(np.clip(cos_theta, -1.0, 1.0))
    lit = np.maximum(np.cos(theta[:, None] + x[None, :]), 0.0)
    return lit @ (g * wts), float(np.dot(g, wts))


def ring_lut(gaussians: list[tuple[float, tuple[float, float, float]]], size: int,
             max_curvature: float) -> FloatArray:
    """D(theta, r) as an RGB table (rows: curvature 1/r from 0 to ``max_curvature`` mm^-1 at texel
    centres, columns: N.L from -1 to 1 at texel centres). ``gaussians``: (variance mm^2, RGB weights)."""
    n = int(size)
    ndl = (np.arange(n) + 0.5) / n * 2.0 - 1.0
    kappa = (np.arange(n) + 0.5) / n * float(max_curvature)
    out = np.zeros((n, n, 3))
    for row, k in enumerate(kappa):
        if k <= 0.0:
            out[row] = np.maximum(ndl, 0.0)[:, None]
            continue
        num = np.zeros((n, 3))
        den = np.zeros(3)
        for v, w in gaussians:
            if v <= 0.0 or max(w) <= 0.0:
                continue
            a, b = _ring_terms(float(v), 1.0 / k, ndl)
            wv = np.asarray(w, np.float64)
            num += a[:, None] * wv[None, :]
            den += b * wv
        with np.errstate(invalid="ignore", divide="ignore"):
            out[row] = np.where(den > 0, num / np.where(den > 0, den, 1.0), np.maximum(ndl, 0.0)[:, None])
    return out.astype(np.float32)


def env_band_factors(ring: np.ndarray) -> np.ndarray:
    """(rows, 3, 3) float32: for each curvature row of ``ring`` (ring_lut) and SH band l = 0, 1, 2, the
    factor w_l(k) (RGB) by which pre-integration scales the environment's band-l irradiance: by
    Funk-Hecke, the zonal kernel D(N.w, k) has the band weights lambda_l = 2 pi int D(mu) P_l(mu) d mu,
    so int L(w) D(N.w, k) dw = sum_lm lambda_l(k) L_lm Y_lm(N) (R&H 2001 eq. 7 with D for the
    clamped cosine); w_l = lambda_l(k) / lambda_l(max(mu, 0)), both by the same midpoint rule over
    the table's N.L columns, so a flat row (k = 0) gives exactly 1 (lib/environment.glsl
    env_irradiance_scattered)."""
    ring = np.asarray(ring, np.float64)
    n = ring.shape[1]
    mu = (np.arange(n) + 0.5) / n * 2.0 - 1.0
    P = np.stack([np.ones_like(mu), mu, 0.5 * (3.0 * mu * mu - 1.0)])  # Legendre P_0..P_2
    lam = np.einsum("lj,rjc->rlc", P, ring)  # the common factor 2 pi (2 / n) cancels
    lam0 = P @ np.maximum(mu, 0.0)
    out: np.ndarray = (lam / lam0[None, :, None]).astype(np.float32)
    return out


def ring_integral(gaussians: Any, theta: float, r: float, samples: int = 200001) -> np.ndarray:
    """The ring integral D(theta, r) by brute force over [-pi, pi] (the tests' independent answer)."""
    x = np.linspace(-math.pi, math.pi, samples)
    d = 2.0 * r * np.abs(np.sin(x / 2.0))
    lit = np.maximum(np.cos(theta + x), 0.0)
    num = np.zeros(3)
    den = np.zeros(3)
    for v, w in gaussians:
        g = _gaussian_2d(float(v), d)
        num += np.trapezoid(lit * g, x) * np.asarray(w, np.float64)
        den += np.trapezoid(g, x) * np.asarray(w, np.float64)
    return num / den


def edge_profile(gaussians: Iterable[tuple[float, ArrayLike]], x: FloatArray) -> FloatArray:
    """A hard light edge at x = 0 (lit for x > 0) diffused by the profile, per channel:
    sum_i w_i Phi(x / sqrt(v_i)) / sum_i w_i (the step convolved with a_p, design/screen_space.md §3.3.2)."""
    x = np.asarray(x, np.float64)
    out = np.zeros(x.shape + (3,))
    total = np.zeros(3)
    for v, w in gaussians:
        wv = np.asarray(w, np.float64)
        if v <= 0.0 or float(wv.max()) <= 0.0:
            continue

        phi = 0.5 * (1.0 + _erf(x / math.sqrt(2.0 * v)))
        out += phi[..., None] * wv
        total += wv
    return out / np.where(total > 0, total, 1.0)


def _erf(x: FloatArray) -> FloatArray:
    from scipy.special import erf
    out: FloatArray = erf(x)
    return out


def penumbra_lut(gaussians: Iterable[tuple[float, ArrayLike]], size: int, max_width_mm: float) -> FloatArray:
    """Shadow scattering (rows: the PCF penumbra's world width W from 0 to ``max_width_mm`` at texel
    centres; columns: the PCF shadow value s from 0 to 1 at texel centres), RGB. The filtered shadow is
    a linear ramp of width W across a hard edge; a point with value s sits at x = (s - 1/2) W and
    receives the hard edge diffused by the profile, edge_profile(x): the narrow green and blue keep a
    sharp edge, red bleeds into the shadow. Rescaled so that s = 0 stays 0 and s = 1 stays 1: the
    filter cannot tell how far past the ramp's ends a point lies, and fully shadowed skin must not
    gain light from nowhere (nor fully lit skin lose it)."""
    n = int(size)
    s = (np.arange(n) + 0.5) / n
    widths = (np.arange(n) + 0.5) / n * float(max_width_mm)
    xs = (np.concatenate(([0.0], s, [1.0])) - 0.5)[None, :] * widths[:, None]
    vals = edge_profile(gaussians, xs)  # (n, n + 2, 3)
    lo, hi = vals[:, :1], vals[:, -1:]
    out = (vals[:, 1:-1] - lo) / np.maximum(hi - lo, 1e-9)
    return np.clip(out, 0.0, 1.0).astype(np.float32)


def vertex_curvature(positions: FloatArray, normals: FloatArray, indices: FloatArray, mm_per_unit: float,
                     ids: FloatArray | None = None) -> FloatArray:
    """Per vertex, the mean over its edges of |n_i - n_j| / |p_i - p_j| in mm^-1 (Penner's |dN| / |dP|,
    taken along the mesh's edges instead of screen derivatives): on a sphere of radius R both are
    2 sin(phi/2) apart (unit normals, chord 2 R sin(phi/2)), so exactly 1/R. ``ids``: one id per point
    of the surface (scene.mesh.position_ids): copies of a vertex along a UV seam share their mean, so a
    seam shows no step."""
    p = np.asarray(positions, np.float64) * float(mm_per_unit)
    nrm = np.asarray(normals, np.float64)
    tri = np.asarray(indices, np.int64)
    e = np.concatenate([tri[:, [0, 1]], tri[:, [1, 2]], tri[:, [2, 0]]])
    e = np.unique(np.sort(e, axis=1), axis=0)
    length = np.linalg.norm(p[e[:, 0]] - p[e[:, 1]], axis=1)
    e, length = e[length > 0], length[length > 0]
    k = np.linalg.norm(nrm[e[:, 0]] - nrm[e[:, 1]], axis=1) / length
    total = np.bincount(e.ravel(), weights=np.repeat(k, 2), minlength=len(p))
    count = np.bincount(e.ravel(), minlength=len(p)).astype(np.float64)
    if ids is not None:
        inv = np.unique(np.asarray(ids), return_inverse=True)[1].ravel()
        total = np.bincount(inv, weights=total)[inv]
        count = np.bincount(inv, weights=count)[inv].astype(np.float64)
    return (total / np.maximum(count, 1.0)).astype(np.float32)
