"""Reference maths of the screen-space techniques of seed 001 ch. 3, in numpy (the GLSL of
skinviewer/passes/screen_space must agree with it):

* Jimenez et al. 2009 (seed 001 §3.2, eq. 3.2): stretch factors s = alpha / (d + beta |grad d|) and
  the N-tap Gaussian kernel each 1-D pass uses (spec §3.2 GAPs, our choices below).
* Jimenez et al. 2015 separable SSS (seed 001 §3.3; spec §4.2, [SEP] calculateKernel): the
  pre-integrated separable kernel of the d'Eon profile with the strength/falloff artist model,
  its tap offsets on screen, the follow-surface lerp, the inner-tap rotation.

Units: profile distances and variances in mm (mm^2), depths in mm, screen offsets in pixels.
"""
from __future__ import annotations

import math
from collections.abc import Iterable

import numpy as np
from numpy.typing import ArrayLike

from skinviewer.physics.arrays import FloatArray

# -- Jimenez 2009 ---------------------------------------------------------------------------------

SSSS_ALPHA_REF = 11.0  # the alpha at which s is the true projection (spec §3.2: alpha absorbs fov/units)


def focal_px(fov_y_deg: float, height: int) -> float:
    """Pixels per mm at 1 mm depth: H / (2 tan(fov_y / 2))."""
    return height / (2.0 * math.tan(math.radians(fov_y_deg) / 2.0))


def stretch_px_per_mm(depth_mm: ArrayLike, grad_mm_per_px: ArrayLike, alpha: float, beta: float, focal: float
                      ) -> FloatArray:
    """eq. 3.2, s = alpha / (d + beta |grad d|), in pixels per mm of surface: (alpha / 11) x focal /
    (d + beta |grad d|). d is the linear depth (mm), grad its screen derivative (mm per pixel,
    per 2x2 quad). With alpha = 11 and beta = 0 it is the exact projection focal / d (a GAP of
    the thesis, spec §3.2: alpha absorbs fov, resolution and units; here it is calibrated)."""
    d = np.asarray(depth_mm, dtype=np.float64)
    g = np.abs(np.asarray(grad_mm_per_px, dtype=np.float64))
    return (alpha / SSSS_ALPHA_REF) * focal / np.maximum(d + beta * g, 1e-6)


def gaussian_taps(n: int, extent: float = 3.0) -> tuple[FloatArray, FloatArray]:
    """The 1-D kernel of one blur of std 1: n odd taps evenly over +-extent, weights
    exp(-x^2 / 2 s^2) normalised, s solved so the discrete variance is exactly 1 (as d'Eon's
    KERNEL7, skinviewer.physics.diffusion: the incremental chain's variances then add up, seed 000
    eq. 24; truncating at +-3 with dense taps otherwise loses ~3 % per blur). n = 7: taps one
    sigma apart (seed 000 eq. 25). Returns (offsets, weights)."""
    if n < 3 or n % 2 == 0:
        raise ValueError(f"tap count must be odd and >= 3 (got {n})")
    x = np.linspace(-extent, extent, n)

    def kernel(s: float) -> FloatArray:
        w = np.exp(-0.5 * (x / s) ** 2)
        return w / float(w.sum())

    lo, hi = 0.5, 4.0
    for _ in range(80):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if float(np.sum(kernel(mid) * x * x)) < 1.0 else (lo, mid)
    return x, kernel(0.5 * (lo + hi))


def bilinear_variance(step_px: float, offsets: ArrayLike, weights: ArrayLike) -> float:
    """Variance (px^2) that bilinear fetches add to a 1-D kernel with taps at offsets x step_px:
    a fetch at fractional position f is a 2-tap kernel (1 - f, f) of variance f (1 - f)."""
    f = np.mod(np.abs(np.asarray(offsets, np.float64) * step_px), 1.0)
    return float(np.sum(np.asarray(weights, np.float64) * f * (1.0 - f)))


def bilinear_compensated_step(sigma_px: float, offsets: ArrayLike, weights: ArrayLike, iterations: int = 2) -> float:
    """The tap spacing (px per kernel unit) at which a unit-variance kernel sampled bilinearly has
    variance sigma_px^2: step^2 + bilinear_variance(step) = sigma^2 (2 fixed-point steps, as the
    GLSL of ss_gauss_blur). Without it every blur of the incremental chain is ~0.15 px^2 too wide
    and denser taps get worse, not better (measured on the laser: 7 -> 25 taps, 2 % -> 7.5 %)."""
    step = float(sigma_px)
    for _ in range(iterations):
        step = math.sqrt(max(sigma_px * sigma_px - bilinear_variance(step, offsets, weights), 0.0))
    return step


def incremental_sigmas(variances: Iterable[float]) -> list[float]:
    """Standard deviations of the incremental blurs: blur_i = blur_(i-1) x G(v_i - v_(i-1))
    (seed 000 eq. 24; spec §3.2). A non-ascending variance gives a zero increment."""
    out, prev = [], 0.0
    for v in variances:
        out.append(math.sqrt(max(float(v) - prev, 0.0)))
        prev = max(prev, float(v))
    return out


def limit_gaussians(gaussians: Iterable[tuple[float, ArrayLike]], count: int) -> list[tuple[float, FloatArray]]:
    """The first ``count`` Gaussians (variance, RGB weights) of the profile; the weight of those
    dropped moves to the widest kept one, so each channel keeps its energy (the bench's
    Gaussian-count knob)."""
    gs = [(float(v), np.asarray(w, dtype=np.float64).copy()) for v, w in gaussians]
    if count >= len(gs):
        return gs
    kept = gs[:max(count, 1)]
    for _, w in gs[len(kept):]:
        kept[-1][1][:] += w
    return kept


# -- Jimenez 2015 separable SSS ------------------------------------------------------------------

# [SEP] calculateKernel's profile: the red d'Eon weights for all channels, the 0.0064 mm^2 term
# dropped (it is carried by the strength lerp)
SEP_PROFILE = ((0.100, 0.0484), (0.118, 0.187), (0.113, 0.567), (0.358, 1.99), (0.078, 7.41))


def kernel_range(n: int) -> float:
    return 3.0 if n > 20 else 2.0


def kernel_offsets(n: int) -> FloatArray:
    """spec §4.2 steps 1-2: n uniform parameters over +-RANGE warped quadratically to the centre
    (x = sign(o) o^2 / RANGE), in profile mm, ascending."""
    if n < 3 or n % 2 == 0:
        raise ValueError(f"tap count must be odd and >= 3 (got {n})")
    rng = kernel_range(n)
    o = -rng + np.arange(n) * (2.0 * rng / (n - 1))
    out: FloatArray = np.where(o >= 0, 1.0, -1.0) * o * o / rng
    return out


def sep_profile(r: ArrayLike, falloff: ArrayLike) -> FloatArray:
    """spec §4.2 step 4: P_c(r) = sum w_k exp(-(r / (0.001 + falloff_c))^2 / 2 v_k) / (2 pi v_k),
    per channel: (..., 3). [SEP] uses 3.14 for pi; the kernel is normalised afterwards."""
    r = np.asarray(r, dtype=np.float64)[..., None]
    f = 0.001 + np.asarray(falloff, dtype=np.float64)
    rr = r / f
    out = np.zeros(rr.shape)
    for w, v in SEP_PROFILE:
        out += w * np.exp(-rr * rr / (2.0 * v)) / (2.0 * 3.14 * v)
    return out


def separable_kernel(n: int, strength: ArrayLike = (0.48, 0.41, 0.28), falloff: ArrayLike = (1.0, 0.37, 0.30)) -> tuple[FloatArray, FloatArray]:
    """The pre-integrated separable kernel (seed 001 §3.3.2-3.3.3; spec §4.2 steps 1-6). Returns
    (weights (n, 3), offsets (n,) in profile mm), the centre tap first (index 0), then the taps in
    ascending offset order as [SEP] stores them. Each channel sums to 1."""
    x = kernel_offsets(n)
    area = np.zeros(n)
    area[1:] += np.abs(x[1:] - x[:-1]) / 2.0
    area[:-1] += np.abs(x[:-1] - x[1:]) / 2.0
    k = area[:, None] * sep_profile(x, falloff)
    c = n // 2
    order = [c] + [i for i in range(n) if i != c]
    k, x = k[order], x[order]
    k = k / k.sum(axis=0, keepdims=True)
    s = np.clip(np.asarray(strength, dtype=np.float64), 0.0, 1.0)
    k = k * s
    k[0] += 1.0 - s
    return k, x


def tap_offset_px(x_mm: ArrayLike, width_mm: float, depth_mm: ArrayLike, focal: float) -> FloatArray:
    """Screen offset (pixels) of a tap at profile distance x: the kernel's +-3 profile mm span
    width_mm of surface (sssWidth, spec §4.2 blur step 3), projected at depth d: x (width / 3)
    focal / d. [SEP] folds the factor 2 and the aspect of its UV step into sssWidth; ours is exact."""
    return np.asarray(x_mm, dtype=np.float64) * (width_mm / 3.0) * focal / np.maximum(np.asarray(depth_mm, np.float64), 1e-6)


def follow_surface(tap: ArrayLike, centre: ArrayLike, dz_mm: ArrayLike, threshold_mm: float) -> FloatArray:
    """spec §4.2 blur step 5: the tap's colour lerped to the centre's by saturate(|dz| / threshold)
    ([SEP]: threshold = 1 / (300 D sssWidth) in its units)."""
    t = np.clip(np.abs(np.asarray(dz_mm, np.float64)) / threshold_mm, 0.0, 1.0)[..., None]
    return np.asarray(tap, np.float64) * (1.0 - t) + np.asarray(centre, np.float64) * t


def preintegrated_gaussians(x: ArrayLike, gaussians: Iterable[tuple[float, ArrayLike]]) -> FloatArray:
    """seed 001 eq. 3.5 for a sum of Gaussians: a_p(x) = sum w_i exp(-x^2 / 2 v_i) / sqrt(2 pi v_i)."""
    xa = np.asarray(x, dtype=np.float64)[..., None]
    out: FloatArray | float = 0.0
    for v, w in gaussians:
        out = out + np.asarray(w, np.float64) * np.exp(-xa * xa / (2.0 * v)) / math.sqrt(2.0 * math.pi * v)
    return np.asarray(out)


def rotated_taps(offsets: ArrayLike, fraction: float, angle: float) -> FloatArray:
    """Tap positions (n, 2) of a horizontal pass whose inner taps (|x| <= fraction x max|x|,
    seed 001 §3.3.4) are rotated by ``angle``; the vertical pass uses the same rotation of (0, 1)."""
    x = np.asarray(offsets, np.float64)
    inner = np.abs(x) <= fraction * np.max(np.abs(x)) + 1e-12
    c, s = math.cos(angle), math.sin(angle)
    return np.stack([np.where(inner, c * x, x), np.where(inner, s * x, 0.0)], axis=-1)
