"""Reference maths of the d'Eon & Luebke 2007 technique (seed 000 §4.2 eq. 20-35, seed 002 §14.4),
in numpy: the Gaussian of eq. (20), the sum-of-Gaussians profile (21), the 7-tap separable kernel
used by every blur (eq. 25-26), the hierarchical blur plan (eq. 24) and the TSM separability
identity behind eq. (33).

Units: variances in mm^2, distances in mm.
"""
from __future__ import annotations

from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from typing import Any, Protocol, runtime_checkable

import numpy as np
from numpy.typing import ArrayLike, NDArray

from skinviewer.physics.arrays import Float32Array, FloatArray, IndexArray


@runtime_checkable
class GaussianTerm(Protocol):
    """One term of a sum of Gaussians as the settings hold it (``DeonSettings.gaussians``)."""
    @property
    def variance(self) -> float: ...
    @property
    def weights(self) -> Sequence[float]: ...

# -- eq. (20), (21) ----------------------------------------------------------------------------


def gaussian(v: ArrayLike, r: ArrayLike) -> FloatArray:
    """eq. (20): G(v, r) = exp(-r^2 / 2v) / (2 pi v), a 2D radial Gaussian of unit integral.
    v = 0 is a delta (returns 0 for r > 0; never NaN)."""
    va = np.asarray(v, dtype=np.float64)
    ra = np.asarray(r, dtype=np.float64)
    vv = np.maximum(va, 1e-300)
    with np.errstate(under="ignore", over="ignore"):
        g = np.exp(-(ra * ra) / (2.0 * vv)) / (2.0 * np.pi * vv)
    return np.where(va > 0, g, 0.0)


def profile(r: ArrayLike, gaussians: Iterable[GaussianTerm | Sequence[Any]]) -> FloatArray:
    """eq. (21): R(r) = sum_i w_i G(v_i, r), per channel: returns (..., 3)."""
    ra = np.asarray(r, dtype=np.float64)
    out = np.zeros(ra.shape + (3,))
    for g in gaussians:
        v, w = _vw(g)
        out += gaussian(v, ra)[..., None] * np.asarray(w, dtype=np.float64)
    return out


def _vw(g: GaussianTerm | Sequence[Any]) -> tuple[float, tuple[float, ...]]:
    """(variance, weights) of a settings term or a (variance, weights) pair."""
    if isinstance(g, GaussianTerm):
        return float(g.variance), tuple(g.weights)

    return float(g[0]), tuple(g[1])


# -- the TSM identity behind eq. (33) ----------------------------------------------------------


def tsm_factor(d: ArrayLike, v: ArrayLike, form: str = "exact") -> FloatArray:
    """Attenuation of Gaussian v for a thickness d (mm): exact separability
    G(v, sqrt(r^2 + d^2)) = G(v, r) exp(-d^2 / 2v) gives exp(-d^2/(2v)) ("exact"); seed 000 prints
    exp(-d^2/v) ("printed"). v = 0: 1 at d = 0, else 0. Never NaN for finite input."""
    da = np.asarray(d, dtype=np.float64)
    va = np.asarray(v, dtype=np.float64)
    denom = (2.0 if form == "exact" else 1.0) * np.maximum(va, 1e-300)
    with np.errstate(under="ignore", over="ignore"):
        f = np.exp(-(da * da) / denom)
    return np.where(va > 0, f, (da == 0).astype(np.float64))


# -- the 7-tap kernel (eq. 25-26) --------------------------------------------------------------
# Offsets are -3..3 tap spacings, the spacing being the increment's standard deviation sigma
# (eq. 25: radius = texel size * stretch * sigma). Weights: the unit Gaussian sampled at the
# integers, exp(-k^2 / 2s^2), with s solved so that the discrete kernel's variance is exactly 1
# (in tap units): the blur adds exactly v_i - v_(i-1) of variance, so the hierarchical chain's
# variances add up as eq. (24) says. s = 1.0021; weights 0.0045, 0.0543, 0.2420, 0.3982, ...
# GPU Gems 3 listing 14-5 prints {0.006, 0.061, 0.242, 0.382, ...}: its variance is 1.08 (8 % too
# wide per blur, compounding down the chain), so it is not used.
TAP_OFFSETS = np.arange(-3, 4, dtype=np.float64)


def _kernel(s: float) -> FloatArray:
    w = np.exp(-TAP_OFFSETS ** 2 / (2.0 * s * s))
    return w / float(w.sum())


def _solve_kernel() -> FloatArray:
    lo, hi = 0.5, 2.0
    for _ in range(80):
        mid = 0.5 * (lo + hi)
        var = float(np.sum(_kernel(mid) * TAP_OFFSETS ** 2))
        lo, hi = (mid, hi) if var < 1.0 else (lo, mid)
    return _kernel(0.5 * (lo + hi))


KERNEL7 = _solve_kernel()

# Narrow inputs. Seven taps one sigma apart reproduce a Gaussian only when the texture being
# blurred is already smooth at that spacing: copies of a Gaussian of std s spaced h apart ripple by
# ~2 exp(-2 pi^2 s^2 / h^2) (10 % at s/h = 0.39: blur 2 of the skin profile). Denser taps
# (t = sigma/h > 1) were tried: on the laser test (1024^2, 24 mm slab) truncating at +-3 taps =
# +-1.9 sigma (t = 1.6) cut the blue tail at r = 0.4 mm by 56 % and doubled the r-weighted error
# (B 4.4 % -> 9.5 %), so every blur keeps eq. (25)'s spacing of one sigma, and a too-narrow input
# is handled by splitting the increment instead (``sub_steps``, SMOOTH_RATIO).
SMOOTH_RATIO = 0.6

GPU_GEMS_KERNEL7 = np.array([0.006, 0.061, 0.242, 0.382, 0.242, 0.061, 0.006])


# -- the hierarchical blur plan (eq. 24) -------------------------------------------------------


@dataclass(frozen=True)
class BlurStep:
    index: int  # Gaussian i (0-based)
    source: str  # resource blurred: "deon_irradiance" or "blur_{i-1}"
    increment: float  # variance (mm^2) added by this blur, >= 0
    variance: float  # variance the result actually has (mm^2)
    reused: bool  # blur_i *is* its source (the irradiance, or a folded sub-texel step): no pass


IRRADIANCE = "deon_irradiance"


def blur_resource(i: int) -> str:
    return f"blur_{i}"


def stretch_blur_resource(i: int) -> str:
    """The stretch map convolved like blur_i (seed 000 end of §4.2.4)."""
    return f"stretch_blur_{i}"


def blur_plan(variances: Iterable[float], reuse_below: float, fold_below: float = 0.0) -> list[BlurStep]:
    """One step per Gaussian. blur_i = blur_(i-1) (x) G(v_i - var(blur_(i-1))) with the increment
    clamped to >= 0 (non-ascending variances: blur_i = blur_(i-1)); the first Gaussian reuses the
    irradiance itself (variance 0) when v_1 < reuse_below. The increment is measured from the
    variance the previous texture really has, so a reused or clamped step does not lose width.
    ``fold_below`` (variance, mm^2): a later step whose increment is under it is folded too, blur_i
    = its source; the next real step then adds the folded variance exactly (issue 14)."""
    steps: list[BlurStep] = []
    have = 0.0
    src = IRRADIANCE
    for i, v in enumerate(variances):
        v = max(float(v), 0.0)
        if i == 0 and v < reuse_below:
            steps.append(BlurStep(0, IRRADIANCE, 0.0, 0.0, True))
            continue
        inc = max(v - have, 0.0)
        if i > 0 and inc < fold_below:
            steps.append(BlurStep(i, src, 0.0, have, True))
            continue
        steps.append(BlurStep(i, src, inc, have + inc, False))
        have += inc
        src = blur_resource(i)
    return steps


def blur_plan_texels(variances: Iterable[float], reuse_below_texels: float, texel_mm: float,
                     fold_below_texels: float = 0.0) -> list[BlurStep]:
    """blur_plan with the reuse threshold relative to the texel: blur_1 is the irradiance itself
    when sigma_1 < reuse_below_texels * texel_mm (a sub-texel blur would change nothing; a fixed
    variance threshold instead skips a blur the laser needs at fine texel sizes)."""
    return blur_plan(variances, (max(reuse_below_texels, 0.0) * texel_mm) ** 2,
                     (max(fold_below_texels, 0.0) * texel_mm) ** 2)


def texture_of(step: BlurStep) -> str:
    """The resource holding Gaussian ``step.index``'s blurred irradiance."""
    return step.source if step.reused else blur_resource(step.index)


def uniform_uv_per_mm(positions: ArrayLike, uvs: ArrayLike, indices: IndexArray, mm_per_unit: float) -> float:
    """The stretch used when stretch correction is off: one isotropic scale, sqrt(UV area / world
    area in mm^2) over the whole mesh (so mm scaling stays right on average, distortion is not
    corrected)."""
    p = np.asarray(positions, dtype=np.float64)[indices]
    t = np.asarray(uvs, dtype=np.float64)[indices]
    a_w = 0.5 * np.linalg.norm(np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]), axis=1).sum()
    e1, e2 = t[:, 1] - t[:, 0], t[:, 2] - t[:, 0]
    a_t = 0.5 * np.abs(e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0]).sum()
    a_w *= float(mm_per_unit) ** 2
    if not (a_w > 0 and a_t > 0 and np.isfinite(a_w) and np.isfinite(a_t)):
        return 1.0
    return float(np.sqrt(a_t / a_w))


MAX_UV_PER_MM = 10.0  # deon_stretch.frag's clamp (tiny or zero world area)


def uv_jacobians(positions: ArrayLike, uvs: ArrayLike, indices: IndexArray, mm_per_unit: float
                 ) -> tuple[FloatArray, FloatArray, NDArray[np.bool_]]:
    """Per triangle, the UV -> surface Jacobian's columns dP/du, dP/dv (mm per UV unit; seed 000
    eq. 27) and whether the triangle has a UV area at all (``ok``): (pu, pv, ok)."""
    p = np.asarray(positions, dtype=np.float64)[indices] * float(mm_per_unit)
    t = np.asarray(uvs, dtype=np.float64)[indices]
    e1, e2 = p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]
    t1, t2 = t[:, 1] - t[:, 0], t[:, 2] - t[:, 0]
    det = t1[:, 0] * t2[:, 1] - t2[:, 0] * t1[:, 1]
    ok = (np.abs(det) > 1e-20) & np.isfinite(det)
    d = np.where(ok, det, 1.0)[:, None]
    with np.errstate(invalid="ignore", over="ignore"):
        pu = np.where(ok[:, None], (e1 * t2[:, 1:2] - e2 * t1[:, 1:2]) / d, 0.0)
        pv = np.where(ok[:, None], (e2 * t1[:, 0:1] - e1 * t2[:, 0:1]) / d, 0.0)
    return pu, pv, ok & np.isfinite(pu).all(1) & np.isfinite(pv).all(1)


def max_uv_per_mm(positions: ArrayLike, uvs: ArrayLike, indices: IndexArray, mm_per_unit: float) -> float:
    """A bound on the stretch map (UV per mm, seed 000 eq. 27), known without reading it back: the
    largest per-axis UV standard deviation of a unit surface Gaussian, sqrt(S_uu), sqrt(S_vv) of
    S = (J^T J)^-1 per triangle (triangle_uv_covariance). It bounds deon_stretch.frag's per-triangle
    1/|dP/du| (S_uu = 1 / (|dP/du|^2 sin^2)) and, S being convex in the vertex mode, its interpolated
    one too."""
    S, ok, _ = triangle_uv_covariance(positions, uvs, indices, mm_per_unit)
    if not ok.any():
        return MAX_UV_PER_MM
    return float(np.clip(np.sqrt(S[ok][:, [0, 2]].max()), 1e-7, MAX_UV_PER_MM))


def triangle_uv_covariance(positions: ArrayLike, uvs: ArrayLike, indices: IndexArray, mm_per_unit: float
                           ) -> tuple[FloatArray, NDArray[np.bool_], FloatArray]:
    """Per triangle (S_uu, S_uv, S_vv) = (J^T J)^-1, UV^2 per mm^2, clamped like deon_stretch.frag
    (per axis at most MAX_UV_PER_MM^2; a triangle with no surface area gets the clamp), whether it
    has a UV area (ok: it is rasterised in texture space) and its surface area (mm^2; 0 if none)."""
    pu, pv, ok = uv_jacobians(positions, uvs, indices, mm_per_unit)
    E, F, G = (pu * pu).sum(1), (pu * pv).sum(1), (pv * pv).sum(1)
    det = E * G - F * F
    surface = ok & (det > 1e-30 * np.maximum(E * G, 1e-300))
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        S = np.stack([G / det, -F / det, E / det], axis=1)  # G^-1 = [[G, -F], [-F, E]] / det
    lim = MAX_UV_PER_MM ** 2
    S = np.where(surface[:, None] & np.isfinite(S).all(1, keepdims=True), S, [lim, 0.0, lim])
    S /= np.maximum(np.maximum(S[:, 0], S[:, 2]) / lim, 1.0)[:, None]  # a tiny surface triangle: as clamped
    area = 0.5 * np.sqrt(np.maximum(det, 0.0)) * np.abs(_uv_area2(uvs, indices))
    return S, ok, np.where(surface & np.isfinite(area), area, 0.0)


def max_shear_cos(positions: ArrayLike, uvs: ArrayLike, indices: IndexArray, mm_per_unit: float) -> float:
    """The largest |cos| of the angle between dP/du and dP/dv over the mesh's triangles (0: the UV
    axes are orthogonal on the surface everywhere, so a shear-following blur is the per-axis one)."""
    pu, pv, ok = uv_jacobians(positions, uvs, indices, mm_per_unit)
    if not ok.any():
        return 0.0
    lu, lv = np.linalg.norm(pu[ok], axis=1), np.linalg.norm(pv[ok], axis=1)
    with np.errstate(divide="ignore", invalid="ignore"):
        c = np.abs((pu[ok] * pv[ok]).sum(1)) / (lu * lv)
    return float(np.nan_to_num(c, nan=0.0).max())


def vertex_uv_covariance(positions: ArrayLike, uvs: ArrayLike, indices: IndexArray, mm_per_unit: float
                         ) -> Float32Array:
    """(N, 3) float32 per vertex: (S_uu, S_uv, S_vv), the UV covariance of a unit surface Gaussian,
    S = G^-1 with G = J^T J the metric of the UV -> surface Jacobian (seed 000 eq. 27 without
    dropping the shear; UV^2 per mm^2). A blur of sigma mm needs the UV covariance sigma^2 S.
    Per vertex it is the mean of its triangles' S weighted by their surface area: the UV covariance
    of a small surface disc around the vertex (a mixture of its triangles' pieces), smooth over the
    surface where the parametrisation is not: a texel that lands in a UV sliver (a triangle squeezed
    in UV, whose own S is ~0 across it, so eq. 27 per triangle would stop the blur there) gets its
    vertices' mixture. Interpolated over a triangle it stays positive definite (a convex
    combination). Vertices are split at UV seams, so each vertex's triangles share one chart.
    Clamped like deon_stretch.frag (per axis <= MAX_UV_PER_MM)."""
    S, _, area = triangle_uv_covariance(positions, uvs, indices, mm_per_unit)
    area = area + 1e-300  # a vertex whose triangles have no surface area: the mean of their clamps
    lim = MAX_UV_PER_MM ** 2
    n = len(np.asarray(positions))
    acc = np.zeros((n, 3))
    wsum = np.zeros(n)
    for k in range(3):
        np.add.at(acc, indices[:, k], S * area[:, None])
        np.add.at(wsum, indices[:, k], area)
    out = np.where(wsum[:, None] > 1e-290, acc / np.maximum(wsum, 1e-300)[:, None], [lim, 0.0, lim])
    return out.astype(np.float32)


def stretch_from_uv_covariance(S: ArrayLike) -> FloatArray:
    """(..., 3) stretch map texels (s_u, s_v, c) from UV covariances (S_uu, S_uv, S_vv), as
    deon_stretch.frag (VERTEX_METRIC) writes them: G = S^-1, s_u = 1/sqrt(G_uu), s_v = 1/sqrt(G_vv)
    (eq. 27's UV per mm along u and v), c = G_uv / sqrt(G_uu G_vv) (the shear, clamped to +-0.95)."""
    Sa = np.asarray(S, np.float64)
    det = Sa[..., 0] * Sa[..., 2] - Sa[..., 1] ** 2
    ok = (det > 0) & (Sa[..., 0] > 0) & (Sa[..., 2] > 0)
    with np.errstate(divide="ignore", invalid="ignore"):
        su = np.sqrt(np.where(ok, det / Sa[..., 2], 1.0))
        sv = np.sqrt(np.where(ok, det / Sa[..., 0], 1.0))
        c = np.where(ok, -Sa[..., 1] / np.sqrt(Sa[..., 0] * Sa[..., 2]), 0.0)
    su = np.where(ok, np.clip(su, 1e-7, MAX_UV_PER_MM), MAX_UV_PER_MM)
    sv = np.where(ok, np.clip(sv, 1e-7, MAX_UV_PER_MM), MAX_UV_PER_MM)
    return np.stack([su, sv, np.clip(c, -0.95, 0.95)], -1)


def _uv_area2(uvs: ArrayLike, indices: IndexArray) -> FloatArray:
    t = np.asarray(uvs, dtype=np.float64)[indices]
    t1, t2 = t[:, 1] - t[:, 0], t[:, 2] - t[:, 0]
    out: FloatArray = t1[:, 0] * t2[:, 1] - t2[:, 0] * t1[:, 1]
    return out


# Bilinear sampling at a fraction f of a texel adds the variance f (1 - f) texel^2 along that axis: 1/6 on
# average for taps at arbitrary offsets, 3/16 for a map read at the centres of one of twice its side.
HALF_PASS_EXTRA = 0.5  # full-size texel^2: a half-size pass's taps, 1/6 of (2 t)^2 instead of 1/6 of t^2
HALF_READ_EXTRA = 0.75  # full-size texel^2: readers at full-size texels filter a half-size map up, 3/16 (2 t)^2
HALF_DOWN_EXTRA = 0.25  # full-size texel^2 per axis: the first half-size pass reads its full-size input
#                         filtered at the half-size texel centres, the 2 x 2 texels around (seam_fill DOWN)


def half_size_increment(increment: float, texel_mm: float, first: bool) -> float:
    """The variance (mm^2) a half-size blur step (deon.half_res_above_texels) blurs with, so that its
    result, as its readers see it, has the variance of the full-size step (eq. 24, variances add): the
    increment less what the coarser grid adds by interpolation (HALF_PASS_EXTRA for its own passes;
    for the first half-size step of a chain also HALF_READ_EXTRA, as every later half-size texture
    inherits it, and HALF_DOWN_EXTRA), in full-size texels ``texel_mm``; never below 0."""
    extra = HALF_PASS_EXTRA + ((HALF_READ_EXTRA + HALF_DOWN_EXTRA) if first else 0.0)
    return max(float(increment) - extra * float(texel_mm) ** 2, 0.0)


def sub_steps(sigma_in: float, increment: float, texel_mm: float, max_steps: int = 8) -> list[float]:
    """Split one blur increment (variance, mm^2) into 7-tap sub-blurs (standard deviations, mm)
    whose tap spacing never exceeds the smoothness of what they blur: sigma_k <= s_k / SMOOTH_RATIO
    with s_k^2 = max(sigma_in, texel/2)^2 + sum of earlier sigma^2. Variances add up to the
    increment exactly (eq. 24). Needed when a texel is much smaller than the first Gaussian (the
    raw irradiance is smooth only at the texel scale: one 7-tap blur leaves 7 spikes)."""
    rest = max(float(increment), 0.0)
    if rest <= 0.0:
        return [0.0]
    s2 = max(float(sigma_in), 0.5 * max(float(texel_mm), 0.0)) ** 2
    out: list[float] = []
    while rest > 0.0 and len(out) < max_steps - 1:
        cap = s2 / SMOOTH_RATIO ** 2 if s2 > 0 else rest
        if cap >= rest:
            break
        out.append(float(np.sqrt(cap)))
        rest -= cap
        s2 += cap
    out.append(float(np.sqrt(rest)))
    return out


def profile_variance(variances: ArrayLike, weights: ArrayLike) -> FloatArray:
    """Per-axis variance (mm^2) of sum_i w_i G(v_i, r) per channel: sum w_i v_i / sum w_i."""
    v = np.asarray(variances, dtype=np.float64)
    w = np.asarray(weights, dtype=np.float64).reshape(len(v), 3)
    s = w.sum(0)
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(s > 0, (w * v[:, None]).sum(0) / s, 0.0)
