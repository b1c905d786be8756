"""Image error metrics, one copy for the bench, the viewer's Accuracy window and the tests.

Every figure is of a linear-radiance image against a reference of the same shape, over a mask of
pixels that count (skin pixels, or every covered pixel):

- ``rel_rms``: relative RMS per channel, sqrt(sum (x - ref)^2 / sum ref^2) over the mask.
- ``p99_rel``: the 99th percentile of the per-pixel relative error |x - ref| / max(ref, floor), per
  channel, where floor = 1 % of the channel's mean reference (so black pixels do not explode it).
- ``dssim``: DSSIM = (1 - SSIM) / 2 (seed 001 eq. 4.3), SSIM of Wang et al. 2004 as implemented by
  scikit-image: Gaussian window sigma = 1.5 truncated at 3.5 sigma (11x11), population covariance,
  C1 = (0.01 L)^2, C2 = (0.03 L)^2 with L = 1; computed on the display-encoded image (exposure, clamp
  to [0, 1], sRGB encoding) channel by channel and averaged over the three channels; with a mask the SSIM
  map is averaged over the mask only. These choices are reported with every number (``DSSIM_SETUP``),
  since seed 001 does not fix them (spec §12.7, T7.2).
"""
from __future__ import annotations

from collections.abc import Iterable
from dataclasses import asdict, dataclass
from typing import Any, cast

import numpy as np
from numpy.typing import ArrayLike

from skinviewer.physics.arrays import BoolArray, FloatArray, IntArray

DSSIM_SETUP = ("SSIM (Wang et al. 2004, scikit-image): Gaussian window sigma 1.5 (11x11), population covariance, "
               "C1=(0.01L)^2, C2=(0.03L)^2, L=1, on sRGB-encoded [0,1] RGB per channel, mean over mask; "
               "DSSIM=(1-SSIM)/2 (seed 001 eq. 4.3)")


def _mask(x: FloatArray, mask: ArrayLike | None) -> BoolArray:
    if mask is None:
        return np.ones(x.shape[:2], bool)
    m = np.asarray(mask).astype(bool)
    if m.shape != x.shape[:2]:
        raise ValueError(f"mask shape {m.shape} does not match the image {x.shape[:2]}")
    return m


def _check(x: FloatArray, ref: FloatArray) -> tuple[FloatArray, FloatArray]:
    x = np.asarray(x, np.float64)[..., :3]
    ref = np.asarray(ref, np.float64)[..., :3]
    if x.shape != ref.shape:
        raise ValueError(f"image shape {x.shape} does not match the reference {ref.shape}")
    if not (np.isfinite(x).all() and np.isfinite(ref).all()):
        raise ValueError("images must be finite")
    return x, ref


def rel_rms(x: FloatArray, ref: FloatArray, mask: ArrayLike | None = None) -> FloatArray:
    """Relative RMS error per channel over the mask (0 for a perfect image)."""
    x, ref = _check(x, ref)
    m = _mask(x, mask)
    d = ((x - ref)[m] ** 2).sum(axis=0)
    n = (ref[m] ** 2).sum(axis=0)
    out: FloatArray = np.sqrt(d / np.maximum(n, 1e-30))
    return out


def rel_error_map(x: FloatArray, ref: FloatArray, mask: ArrayLike | None = None) -> FloatArray:
    """Per-pixel relative error |x - ref| / max(ref, 1 % of the channel mean), per channel; 0 outside the mask."""
    x, ref = _check(x, ref)
    m = _mask(x, mask)
    mean = ref[m].mean(axis=0) if m.any() else np.ones(3)
    floor = np.maximum(0.01 * mean, 1e-12)
    e = np.abs(x - ref) / np.maximum(ref, floor)
    e[~m] = 0.0
    return e


def p99_rel(x: FloatArray, ref: FloatArray, mask: ArrayLike | None = None) -> FloatArray:
    """The 99th percentile of the per-pixel relative error, per channel, over the mask."""
    m = _mask(np.asarray(x), mask)
    e = rel_error_map(x, ref, m)
    return np.percentile(e[m], 99, axis=0) if m.any() else np.zeros(3)


def display_encode(x: FloatArray, exposure: float = 1.0) -> FloatArray:
    """Linear radiance -> the [0, 1] sRGB-encoded values a viewer sees (exposure, clamp, sRGB)."""
    c = np.clip(np.asarray(x, np.float64)[..., :3] * exposure, 0.0, 1.0)
    return np.where(c <= 0.0031308, 12.92 * c, 1.055 * np.power(c, 1.0 / 2.4) - 0.055)


def dssim_map(x: FloatArray, ref: FloatArray, exposure: float = 1.0) -> FloatArray:
    """Per-pixel DSSIM (1 - SSIM) / 2 (seed 001 eq. 4.3; setup ``DSSIM_SETUP``), the channel mean."""
    from skimage.metrics import structural_similarity

    x, ref = _check(x, ref)
    a, b = display_encode(x, exposure), display_encode(ref, exposure)
    _, smap = structural_similarity(a, b, data_range=1.0, channel_axis=-1, gaussian_weights=True, sigma=1.5,
                                    use_sample_covariance=False, full=True)
    out: FloatArray = (1.0 - smap.mean(axis=-1)) / 2.0
    return out


def dssim(x: FloatArray, ref: FloatArray, mask: ArrayLike | None = None, exposure: float = 1.0) -> float:
    """DSSIM = (1 - SSIM) / 2 (seed 001 eq. 4.3), with the setup in ``DSSIM_SETUP``: the mean of
    ``dssim_map`` over the mask."""
    x, ref = _check(x, ref)
    m = _mask(x, mask)
    d = dssim_map(x, ref, exposure)
    return float(np.clip(d[m].mean(), 0.0, 1.0)) if m.any() else 0.0


@dataclass(frozen=True)
class ImageError:
    """The three figures reported everywhere: relative RMS and p99 per channel (R, G, B), and DSSIM;
    with a reference's per-pixel uncertainty, each figure's uncertainty (``figure_uncertainty``)."""
    rms: tuple[float, float, float]
    p99: tuple[float, float, float]
    dssim: float
    rms_u: tuple[float, float, float] | None = None
    p99_u: tuple[float, float, float] | None = None
    dssim_u: float | None = None

    @property
    def rms_mean(self) -> float:
        return float(np.mean(self.rms))

    def to_json(self) -> dict[str, Any]:
        return {**asdict(self), "dssim_setup": DSSIM_SETUP}

    def summary(self) -> str:
        def pct(v: Iterable[float]) -> str:
            return " / ".join(f"{100 * c:.2f}" for c in v)
        if self.rms_u is None or self.p99_u is None or self.dssim_u is None:
            return f"RMS {pct(self.rms)} %  p99 {pct(self.p99)} %  DSSIM {self.dssim:.4f}"
        return (f"RMS {pct(self.rms)} ± {pct(self.rms_u)} %  p99 {pct(self.p99)} ± {pct(self.p99_u)} %  "
                f"DSSIM {self.dssim:.4f} ± {self.dssim_u:.4f}")


def with_u(values: Iterable[float], u: Iterable[float] | None, digits: int = 1, scale: float = 100.0) -> str:
    """'4.2 / 3.1 / 2.0 ± 0.3 / 0.1 / 0.1' (percent by default); without ``u`` just the values."""
    v = " / ".join(f"{scale * c:.{digits}f}" for c in values)
    return v if u is None else v + " ± " + " / ".join(f"{scale * c:.{digits}f}" for c in u)


def figure_uncertainty(x: FloatArray, ref: FloatArray, u: FloatArray, mask: ArrayLike | None = None,
                       exposure: float = 1.0) -> tuple[FloatArray, FloatArray, float]:
    """How far each figure can move while the reference moves by at most its per-pixel uncertainty
    ``u`` (H, W, 3): RMS by the triangle inequality, |rms(x - r') - rms(x - r)| <= rms(r' - r) <=
    rms(u) (over the same norm); p99 between the p99 of (|x - ref| -/+ u)+ / max(ref, floor) (every
    pixel's error lies in that interval and a percentile is monotone); DSSIM: the larger change
    against ref + u and ref - u. Returns (rms_u (3,), p99_u (3,), dssim_u)."""
    x, ref = _check(x, ref)
    u = np.abs(np.asarray(u, np.float64)[..., :3])
    m = _mask(x, mask)
    if not m.any():
        return np.zeros(3), np.zeros(3), 0.0
    rms_u = np.sqrt((u[m] ** 2).sum(0) / np.maximum((ref[m] ** 2).sum(0), 1e-30))
    floor = np.maximum(0.01 * ref[m].mean(axis=0), 1e-12)
    d = np.abs(x - ref)[m]
    den = np.maximum(ref[m], floor)
    p = np.percentile(d / den, 99, axis=0)
    hi = np.percentile((d + u[m]) / den, 99, axis=0)
    lo = np.percentile(np.maximum(d - u[m], 0.0) / den, 99, axis=0)
    p99_u = np.maximum(hi - p, p - lo)
    d0 = dssim(x, ref, m, exposure)
    dssim_u = max(abs(dssim(x, np.maximum(ref + u, 0.0), m, exposure) - d0),
                  abs(dssim(x, np.maximum(ref - u, 0.0), m, exposure) - d0))
    return rms_u, p99_u, float(dssim_u)


def tied(a: float, ua: float | None, b: float, ub: float | None) -> bool:
    """Two figures whose difference is within their uncertainties (either reference's): not ranked."""
    return abs(a - b) <= (ua or 0.0) + (ub or 0.0)


def certainly_better(a: FloatArray, b: FloatArray, ref: FloatArray, u: FloatArray,
                     mask: ArrayLike | None = None) -> BoolArray:
    """Per channel: is image ``a``'s relative RMS below ``b``'s for every truth r + d with |d| <= u at
    every pixel (the ruler's own uncertainty)? Both figures share the denominator sum (r + d)^2, so the
    order is the sign of sum (a - r - d)^2 - (b - r - d)^2 = D0 - 2 sum d (a - b), D0 the difference
    at d = 0, whose largest value over the box is D0 + 2 sum u |a - b|, reached at d = -u sign(a - b).
    So this test is exact (the order holds for every admissible truth iff it returns True), and errors
    the two images share cancel in it, which the per-figure bound (figure_uncertainty, tied) cannot
    see: two configurations of one technique are often ordered by it while their figures' bounds
    overlap."""
    a, ref = _check(a, ref)
    b, _ = _check(b, ref)
    m = _mask(a, mask)
    ua = np.abs(np.asarray(u, np.float64)[..., :3])[m]
    ea, eb = (a - ref)[m], (b - ref)[m]
    d0 = (ea ** 2 - eb ** 2).sum(axis=0)
    out: BoolArray = d0 + 2.0 * (ua * np.abs(a[m] - b[m])).sum(axis=0) < 0.0
    return out


def _rgb(v: Iterable[float]) -> tuple[float, float, float]:
    """A per-channel (R, G, B) array as the tuple of floats ImageError holds."""
    return cast("tuple[float, float, float]", tuple(float(c) for c in v))


def image_error(x: FloatArray, ref: FloatArray, mask: ArrayLike | None = None, exposure: float = 1.0,
                uncertainty: FloatArray | None = None) -> ImageError:
    """The figures; with the reference's per-pixel ``uncertainty`` (H, W, 3) each figure's too."""
    rms = _rgb(rel_rms(x, ref, mask))
    p99 = _rgb(p99_rel(x, ref, mask))
    d = dssim(x, ref, mask, exposure)
    if uncertainty is None:
        return ImageError(rms, p99, d)
    ru, pu, du = figure_uncertainty(x, ref, uncertainty, mask, exposure)
    return ImageError(rms, p99, d, _rgb(ru), _rgb(pu), du)


def _kth_largest_gap(c_lo: FloatArray, c_hi: FloatArray, x: FloatArray, y: FloatArray, k: int) -> float:
    """max over c with c_lo <= c <= c_hi (elementwise) of L_k(c u x) - L_k(c u y), L_k the k-th largest
    (1-based). Every sorted c lies between the sorted bounds, and L_k(c u x) = max_m min(c_(k-m), x_(m))
    (m taken from x, k - m from c; c_(0) = x_(0) = +inf, beyond the end -inf), so only c's order
    statistics k - n .. k matter (n = min(k, len x)). For the split j* attaining the first term at level
    v, the second is smallest with c's statistics as low as the bounds and the order allow (lo_j below
    j*, max(lo_j, v) from it on); the difference then rises with v up to x_(j*) and falls after it, so
    v = clip(x_(j*), lo_j*, hi_j*). A relaxation (c's statistics are bounded one by one), so an upper
    bound; exact when c_lo = c_hi."""
    inf = np.inf
    c_lo_d, c_hi_d = np.sort(c_lo)[::-1], np.sort(c_hi)[::-1]
    xd, yd = np.sort(x)[::-1], np.sort(y)[::-1]
    n = min(k, len(xd))
    j = np.arange(n + 1)

    def stat(d: FloatArray, i: IntArray) -> FloatArray:  # i-th largest, 1-based; 0 -> +inf, past the end -inf
        out = np.full(len(i), -inf)
        out[i == 0] = inf
        ok = (i >= 1) & (i <= len(d))
        out[ok] = d[i[ok] - 1]
        return out
    lo, hi = stat(c_lo_d, k - j), stat(c_hi_d, k - j)
    xm, ym = stat(xd, j), stat(yd, j)
    v = np.minimum(np.maximum(xm, lo), hi)                         # (n+1,) one per j*
    first = np.minimum(v, xm)
    z = np.where(j[None, :] < j[:, None], lo[None, :], np.maximum(lo[None, :], v[:, None]))  # [j*, j]
    second = np.minimum(z, ym[None, :]).max(axis=1)
    with np.errstate(invalid="ignore"):
        gap = first - second
    gap = np.where(np.isnan(gap), -inf, gap)
    return float(gap.max())


def p99_change_bounds(a: FloatArray, b: FloatArray, ref: FloatArray, u: FloatArray,
                      mask: ArrayLike | None = None, same: float = 1e-3) -> tuple[FloatArray, FloatArray]:
    """Per channel (lo (3,), hi (3,)): bounds of p99(a) - p99(b) (``p99_rel``, relative errors over the
    reference's denominators max(ref, floor) as ``figure_uncertainty``) over every truth r + d with
    |d| <= u, both images judged against the *same* truth. The per-figure bounds (``figure_uncertainty``,
    ``tied``) let the two images take opposite truths, so a shared tail pixel whose truth is uncertain
    makes every pair a tie; here a pixel where a and b agree to ``same`` of its denominator counts once
    for both (b taken equal to a there, which moves b's p99 by at most that much: added to the bounds),
    and only the order statistics around the 99th percentile of those shared pixels can move the
    difference (``_kth_largest_gap``); ``same`` x 1, 10, 100, 1000 are tried, each bound is valid, the
    tightest is kept. Pixels where they differ take a at its worst and b at its best
    truth independently (sound, looser there). With u = 0 and same = 0 both bounds are the plain
    difference. The 99th percentile interpolates two order statistics (numpy's linear rule): the bound
    is the same combination of theirs."""
    a, ref = _check(a, ref)
    b, _ = _check(b, ref)
    u = np.abs(np.asarray(u, np.float64)[..., :3])
    m = _mask(a, mask)
    if not m.any():
        return np.zeros(3), np.zeros(3)
    floor = np.maximum(0.01 * ref[m].mean(axis=0), 1e-12)
    den = np.maximum(ref[m], floor)
    da, db, um = np.abs(a - ref)[m] / den, np.abs(b - ref)[m] / den, u[m] / den
    apart = np.abs(a - b)[m] / den
    n = len(da)
    pos = 0.99 * (n - 1)
    i0 = int(np.floor(pos))
    f = pos - i0
    ks = (n - i0, n - min(i0 + 1, n - 1))  # the ascending i-th value is the (n - i)-th largest

    def gap(ex: FloatArray, ey: FloatArray, apart_c: FloatArray, uc: FloatArray) -> float:
        best = np.inf
        for t in sorted({same, *(same * 10.0 ** np.arange(1, 4))}):  # each threshold gives a bound: the least
            d = apart_c > t
            slack = float(apart_c[~d].max()) if (~d).any() else 0.0
            c_lo, c_hi = np.maximum(ex[~d] - uc[~d], 0.0), ex[~d] + uc[~d]
            x_hi, y_lo = ex[d] + uc[d], np.maximum(ey[d] - uc[d], 0.0)
            g = [_kth_largest_gap(c_lo, c_hi, x_hi, y_lo, k) for k in ks]
            best = min(best, (1.0 - f) * g[0] + f * g[1] + slack)
        return best
    hi = np.array([gap(da[:, c], db[:, c], apart[:, c], um[:, c]) for c in range(3)])
    lo = -np.array([gap(db[:, c], da[:, c], apart[:, c], um[:, c]) for c in range(3)])
    return lo, hi


def p99_change(a: FloatArray, b: FloatArray, ref: FloatArray, u: FloatArray, mask: ArrayLike | None = None,
               same: float = 1e-3) -> tuple[str, str, str]:
    """Per channel, how a's p99 stands to b's under every truth within u (``p99_change_bounds``):
    "lower", "higher" or "tie" (the bounds straddle 0: never ranked)."""
    lo, hi = p99_change_bounds(a, b, ref, u, mask, same)
    return cast("tuple[str, str, str]", tuple("lower" if h < 0 else "higher" if l > 0 else "tie"
                                              for l, h in zip(lo, hi)))


def p99_change_witness(a: FloatArray, b: FloatArray, ref: FloatArray, u: FloatArray, mask: ArrayLike | None = None,
                       draws: int = 64, seed: int = 0) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Per channel: p99(a) - p99(b) (relative errors over max(ref, floor), as ``p99_change_bounds``) under
    chosen truths r + d, |d| <= u, both images judged against the *same* one: the extreme truths
    d = +-u sign(a - b), +-u sign(a - r), +-u sign(b - r), +-u, and ``draws`` drawn uniformly in the box
    (seeded). Returns (the smallest and the largest difference found, the share of truths with the sign
    of the difference against r itself), (3,) each. A truth of the opposite sign is a witness: the order
    is then a real tie under the ruler's uncertainty, not one of the bounds' relaxation (which is sound,
    so a decided order has no witness); no witness found does not decide an order, only the bounds do."""
    a, ref = _check(a, ref)
    b, _ = _check(b, ref)
    m = _mask(a, mask)
    if not m.any():
        return np.zeros(3), np.zeros(3), np.ones(3)
    u = np.abs(np.asarray(u, np.float64)[..., :3])[m]
    r, am, bm = ref[m], a[m], b[m]
    den = np.maximum(r, np.maximum(0.01 * r.mean(axis=0), 1e-12))

    def change(d: FloatArray) -> FloatArray:
        t = r + d
        out: FloatArray = (np.percentile(np.abs(am - t) / den, 99, axis=0)
                           - np.percentile(np.abs(bm - t) / den, 99, axis=0))
        return out
    rng = np.random.default_rng(seed)
    ds = [s * u * np.sign(x) for x in (am - bm, am - r, bm - r, np.ones_like(r)) for s in (1.0, -1.0)]
    ds += [u * rng.uniform(-1.0, 1.0, u.shape) for _ in range(int(draws))]
    c0 = change(np.zeros_like(r))
    cs = np.array([change(d) for d in ds])
    return cs.min(axis=0), cs.max(axis=0), (np.sign(cs) == np.sign(c0)[None]).mean(axis=0)
