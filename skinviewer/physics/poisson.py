"""The 12-tap Poisson disk of the Gosselin blur (seed 000 eq. 13: pixel = (centre + sum of 12 taps)/13,
tap i at coord + POISSON_12[i] * radius, eq. 12).

``generate_poisson_disk`` is deterministic (fixed seed, numpy PCG64):
  1. best-candidate dart throwing (Mitchell): 256 independent sets; each new point is the one of 32
     uniform darts in the unit disk farthest from the points already placed;
  2. the 8 sets with the largest minimum distance are relaxed (soft-min repulsion, 400 steps, each
     step re-centred so the centroid is 0 and projected back into the unit disk);
  3. the set with the largest minimum distance wins; it is re-centred, scaled into the disk if needed
     and truncated to 6 decimals (towards 0, so it stays in the disk).
Result: minimum pairwise distance 0.657310 (the best known packing of 12 points in the unit disk
reaches ~0.6602), |centroid| = 1.9e-7 (truncation only: the blur does not shift the image), all taps
within radius 1 (nine on the rim, three inside). ``python -m skinviewer.physics.poisson`` prints the literal.
"""
from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike

from skinviewer.physics.arrays import FloatArray
from skinviewer.physics.diffusion import profile_variance

SEED = 2004  # Gosselin et al. 2004
MIN_DISTANCE = 0.657  # lower bound of POISSON_12's minimum pairwise distance (tested)

# printed by `python -m skinviewer.physics.poisson` (generate_poisson_disk(12, SEED)); tests check they agree
POISSON_12: tuple[tuple[float, float], ...] = (
    (-0.292011, 0.956414),
    (-0.04047, -0.99918),
    (0.974285, -0.225318),
    (-0.991828, -0.127575),
    (0.606397, -0.795161),
    (0.376702, 0.048453),
    (0.385431, 0.922736),
    (-0.682274, -0.731096),
    (-0.146388, -0.35046),
    (-0.230313, 0.302006),
    (0.885551, 0.464542),
    (-0.84508, 0.534638),
)


def _min_dist(p: FloatArray) -> FloatArray:
    """Minimum pairwise distance of point sets p (..., n, 2)."""
    d = np.linalg.norm(p[..., :, None, :] - p[..., None, :, :], axis=-1)
    n = p.shape[-2]
    d[..., np.arange(n), np.arange(n)] = np.inf
    out: FloatArray = d.min(axis=(-2, -1))
    return out


def _uniform_disk(rng: np.random.Generator, shape: tuple[int, ...]) -> FloatArray:
    r = np.sqrt(rng.random(shape))
    a = 2.0 * np.pi * rng.random(shape)
    return np.stack([r * np.cos(a), r * np.sin(a)], axis=-1)


def _best_candidate(rng: np.random.Generator, n: int, sets: int, darts: int) -> FloatArray:
    pts = _uniform_disk(rng, (sets, 1))
    rows = np.arange(sets)
    for _ in range(1, n):
        c = _uniform_disk(rng, (sets, darts))
        d = np.linalg.norm(c[:, :, None, :] - pts[:, None, :, :], axis=-1).min(axis=-1)
        pts = np.concatenate([pts, c[rows, d.argmax(axis=1)][:, None]], axis=1)
    return pts


def _relax(p: FloatArray, steps: int = 400, power: float = 24.0, lr: float = 0.02) -> FloatArray:
    """Push points apart with forces ~ (d_min/d)^power / d (soft min-distance), centroid kept at 0."""
    n = len(p)
    eye = np.eye(n)
    for it in range(steps):
        diff = p[:, None, :] - p[None, :, :]
        d = np.linalg.norm(diff, axis=-1) + eye
        f = (np.min(d + 9.0 * eye) / d) ** power * (1.0 - eye) / d
        g = np.sum(f[..., None] * diff / d[..., None], axis=1)
        p = p + lr * g / (np.abs(g).max() + 1e-300)
        p = p - p.mean(axis=0)
        r = np.linalg.norm(p, axis=1, keepdims=True)
        p = np.where(r > 1.0, p / np.maximum(r, 1.0), p)
        if it % 100 == 99:
            lr *= 0.5
    return p


def generate_poisson_disk(n: int = 12, seed: int = SEED, sets: int = 256, darts: int = 32,
                          relax: int = 8) -> FloatArray:
    """(n, 2) float64 points in the unit disk, deterministic for (n, seed, sets, darts, relax)."""
    rng = np.random.default_rng(seed)
    pts = _best_candidate(rng, n, sets, darts)
    best, best_d = None, -1.0
    for k in np.argsort(-_min_dist(pts), kind="stable")[:relax]:
        q = _relax(pts[k].copy())
        d = float(_min_dist(q))
        if d > best_d:
            best, best_d = q, d
    assert best is not None, "relax >= 1"
    best = best - best.mean(axis=0)
    best = best / max(1.0, float(np.linalg.norm(best, axis=1).max()))
    out: FloatArray = np.trunc(best * 1e6) / 1e6 + 0.0  # 6 decimals towards 0: stays in the disk; no -0.0
    return out


def format_literal(points: FloatArray) -> str:
    rows = "\n".join(f"    ({x!r}, {y!r})," for x, y in np.asarray(points, dtype=np.float64).tolist())
    return f"POISSON_12: tuple[tuple[float, float], ...] = (\n{rows}\n)"


def stats(points: ArrayLike) -> dict[str, float]:
    p = np.asarray(points, dtype=np.float64)
    return {"min_distance": float(_min_dist(p)), "centroid": float(np.linalg.norm(p.mean(axis=0))),
            "max_radius": float(np.linalg.norm(p, axis=1).max())}


if __name__ == "__main__":
    pts = generate_poisson_disk()
    print(format_literal(pts))
    print("#", stats(pts))


def kernel_axis_moment(points: ArrayLike | None = None) -> float:
    """Per-axis second moment of one Poisson blur (eq. 13: the centre and the 12 taps, equal
    weights), in units of the radius R squared: one iteration adds m R^2 of variance per axis."""
    p = np.asarray(POISSON_12 if points is None else points, dtype=np.float64)
    return float(np.sum(p ** 2) / 2.0 / (len(p) + 1))


def radii_mm(variances: ArrayLike, weights: ArrayLike, iterations: int) -> FloatArray:
    """Per-channel Poisson radius (mm) whose ``iterations`` blurs have the sum-of-Gaussians
    profile's per-axis variance V_c = sum_i w_ic v_i / sum_i w_ic (seed 000 eq. 21: a 2D Gaussian of
    variance v spreads v per axis): iterations * m * R_c^2 = V_c (Gosselin's mm mode, issue 10)."""
    V = profile_variance(variances, weights)
    if iterations <= 0:
        return np.zeros(3)
    return np.sqrt(np.maximum(V, 0.0) / (iterations * kernel_axis_moment()))
