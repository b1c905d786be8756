"""The direct gather of a narrow d'Eon blur step (issue 10 item 1), in numpy: the twin of
shaders/deon_gather_blocks.frag + deon_surface_gather.frag, which must agree with it.

A blur step of variance v is seed 000 eq. 21's convolution with 3D distances, summed at texel
resolution over the texels of x's UV island (and its seam-filled gutter):

    out(x) = sum_y G(v, |P(x) - P(y)|) E(y) A(y) / sum_y G(v, |P(x) - P(y)|) A(y)

y: the 36 texels of the 3 x 3 blocks of 2 x 2 texels around x's block, then 2 x 2 blocks out to
``blocks`` blocks, each as one Gaussian widened by its own spread s^2 (moment-matched, as the ground
truth's clusters): (v / (v + s^2)) exp(-r^2 / 2 (v + s^2)), with r to the block's area mean point for
its area and thickness, and to its light's mean point (weight E.r + E.g + E.b) for its light, so a lit
texel beside dark ones stays where it is.

A texel nearer in 3D than SHORTCUT_RATIO x its offset along the surface (from the stretch at x: eq. 27
with shear) is reached across air or a fold (lips, lids, ear folds touching), not along x's sheet: it
is left out, as a texture-space blur leaves it (light through thin parts is the TSM's, eq. 32-33).
Averaged in, it darkened a lit lip by its shadowed neighbour; summed as the ground truth's 3D
distances do, it made texels brighter than any input (energy from nowhere where both are lit).

Inputs per texel: E (n, n, 4) RGB light and A thickness; surface (n, n, 4) the point (mm) and area
(mm^2; 0 not surface; < 0 past a mesh border: area without light beyond PAST_BORDER_SHARE of the
seam-filled value); zone (n, n) the island zone (gutter_table's |B|); stretch (n, n, 3) UV per mm
along u and v and the shear cosine (deon_stretch).
"""
from __future__ import annotations

from collections.abc import Callable, Iterator
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from skinviewer.physics.arrays import FloatArray

PAST_BORDER_SHARE = 0.5  # lib/gather_surface.glsl
SHORTCUT_RATIO = 0.5  # a texel nearer than this x its offset along the surface: across air or a fold
GATHER_BLOCKS = 5  # the outer reach in 2 x 2 blocks at most: 2 * 5 + 2 = 12 texels (3.5 sigma at 3.4 texels)
REACH_SIGMAS = 3.5  # the sum reaches 3.5 sigma (exp(-3.5^2 / 2) = 0.2 % of the centre weight)
STRETCH_HEADROOM = 1.6  # texels at x may be this much smaller than the atlas mean (sigma in mean texels)


def gather_blocks_for(sigma_texels: float) -> int:
    """The reach in 2 x 2 blocks for a step of ``sigma_texels`` mean texels (issue 27: the reach
    follows sigma): REACH_SIGMAS sigma at STRETCH_HEADROOM x the mean texel density, 2 blocks at
    least (the texel ring plus one), GATHER_BLOCKS at most."""
    reach = REACH_SIGMAS * STRETCH_HEADROOM * max(float(sigma_texels), 0.0)
    return int(min(GATHER_BLOCKS, max(2, int(np.ceil((reach - 2.0) / 2.0)))))


def _light(E: FloatArray, w: FloatArray) -> FloatArray:
    """E with its RGB scaled past a border (w < 0)."""
    out = np.array(E, np.float64)
    out[..., :3] *= np.where(w < 0, PAST_BORDER_SHARE, 1.0)[..., None]
    return out


def gather_blocks(E: FloatArray, surface: ArrayLike, zone: ArrayLike) -> dict[str, FloatArray]:
    """deon_gather_blocks.frag: per 2 x 2 block (h = ceil(n / 2)): summed E A (4), the area's mean
    point, area and spread, the light's mean point and spread, and the zone (0: none or mixed)."""
    n = E.shape[0]
    h = (n + 1) // 2
    idx = np.minimum(np.arange(2 * h), n - 1)
    S = np.asarray(surface, np.float64)[idx][:, idx]
    L = _light(np.asarray(E, np.float64), np.asarray(surface)[..., 3])[idx][:, idx]
    Z = np.asarray(zone, np.float64)[idx][:, idx]

    def quads(x: FloatArray) -> FloatArray:  # (2h, 2h, ...) -> (h, h, 4, ...): the block's texels in order k = (k & 1, k >> 1)
        x = x.reshape(h, 2, h, 2, *x.shape[2:])
        return np.stack([x[:, 0, :, 0], x[:, 0, :, 1], x[:, 1, :, 0], x[:, 1, :, 1]], 2)

    S, L, Z = quads(S), quads(L), quads(Z)
    a = np.abs(S[..., 3])
    on = a > 0
    light = (a[..., None] * L).sum(2)
    light[..., :3] = (a[..., None] * L[..., :3]).sum(2)
    origin = S[:, :, 0, :3]
    d = S[..., :3] - origin[:, :, None]
    area = a.sum(2)
    mean = (a[..., None] * d).sum(2) / np.maximum(area, 1e-30)[..., None]
    spread = np.maximum(0.5 * ((a * (d * d).sum(-1)).sum(2) / np.maximum(area, 1e-30) - (mean * mean).sum(-1)), 0.0)
    lw = (a[..., None] * L[..., :3]).sum(-1)
    lsum = lw.sum(2)
    lmean = (lw[..., None] * d).sum(2) / np.maximum(lsum, 1e-30)[..., None]
    lspread = np.maximum(0.5 * ((lw * (d * d).sum(-1)).sum(2) / np.maximum(lsum, 1e-30) - (lmean * lmean).sum(-1)), 0.0)
    has = lsum > 0
    lmean = np.where(has[..., None], lmean, mean)
    lspread = np.where(has, lspread, spread)
    hi, lo = np.where(on, Z, -np.inf).max(2), np.where(on, Z, np.inf).min(2)
    bz = np.where(on.any(2) & (hi == lo), hi, 0.0)
    return {"light": light, "point": origin + mean, "area": area, "spread": spread,
            "lit_point": origin + lmean, "lit_spread": lspread, "zone": bz}


def _sheet_test(st: FloatArray, n: int) -> Callable[[FloatArray, Any, Any], FloatArray]:
    """The sheet test at every x (eq. 27 with shear, from the stretch at x): 0 for an offset d (3D) nearer
    than SHORTCUT_RATIO x its offset (ou, ov) texels along the surface, else 1."""
    mm_u, mm_v = 1.0 / np.maximum(st[..., 0] * n, 1e-30), 1.0 / np.maximum(st[..., 1] * n, 1e-30)
    cs = np.clip(st[..., 2], -0.95, 0.95)

    def sheet(d: FloatArray, ou: NDArray[np.number[Any]], ov: NDArray[np.number[Any]]) -> FloatArray:
        a, b = ou * mm_u, ov * mm_v
        return np.where((d * d).sum(-1) < SHORTCUT_RATIO ** 2 * (a * a + b * b + 2 * cs * a * b), 0.0, 1.0)
    return sheet


def _inner_taps(S: FloatArray, zone: FloatArray, sheet: Callable[[FloatArray, Any, Any], FloatArray],
                v: float) -> Iterator[tuple[Any, Any, FloatArray, FloatArray]]:
    """The 36 texels of the 3 x 3 blocks around x's block, in the shaders' order: per tap (ty, tx, the
    texel's surface, w = G(v, |P(x) - P(y)|) |A(y)| on x's sheet and zone, 0 outside the map)."""
    n = S.shape[0]
    x = S[..., :3]
    yy, xx = np.mgrid[0:n, 0:n]
    by, bx = yy >> 1, xx >> 1
    for j in range(-2, 4):
        for i in range(-2, 4):
            ty, tx = 2 * by + j, 2 * bx + i
            inside = (ty >= 0) & (ty < n) & (tx >= 0) & (tx < n)
            ty, tx = np.clip(ty, 0, n - 1), np.clip(tx, 0, n - 1)
            t = S[ty, tx]
            same = np.abs(zone[ty, tx] - zone) < 0.5
            d = t[..., :3] - x
            yield ty, tx, t, inside * same * sheet(d, tx - xx, ty - yy) * np.abs(t[..., 3]) * np.exp(-0.5 * (d * d).sum(-1) / v)


def _block_tap(B: dict[str, FloatArray], S: FloatArray, zone: FloatArray,
               sheet: Callable[[FloatArray, Any, Any], FloatArray], i: int, j: int) -> tuple[Any, Any, FloatArray, FloatArray]:
    """Outer block (i, j) from x's block: its index (cy, cx), whether it is summed (inside the map, x's
    zone, some area, on x's sheet: 1 or 0) and its area's mean point's offset d from x."""
    n, h = S.shape[0], B["area"].shape[0]
    yy, xx = np.mgrid[0:n, 0:n]
    cy, cx = (yy >> 1) + j, (xx >> 1) + i
    inside = (cy >= 0) & (cy < h) & (cx >= 0) & (cx < h)
    cy, cx = np.clip(cy, 0, h - 1), np.clip(cx, 0, h - 1)
    d = B["point"][cy, cx] - S[..., :3]
    same = (inside & (np.abs(B["zone"][cy, cx] - zone) < 0.5) & (B["area"][cy, cx] > 0)) * sheet(d, 2 * cx - xx + 0.5, 2 * cy - yy + 0.5)
    return cy, cx, same, d


def surface_gather(E: ArrayLike, surface: ArrayLike, zone: ArrayLike, stretch: ArrayLike, v: float, blocks: int = GATHER_BLOCKS) -> FloatArray:
    """deon_surface_gather.frag at every texel (n, n, 4); v the step's variance (mm^2)."""
    E = np.asarray(E, np.float64)
    st = np.asarray(stretch, np.float64)
    S = np.asarray(surface, np.float64)
    zone = np.asarray(zone, np.float64)
    n = E.shape[0]
    v = max(float(v), 1e-30)
    L = _light(E, S[..., 3])
    x = S[..., :3]
    acc = np.zeros((n, n, 4))
    wsum = np.zeros((n, n))
    sheet = _sheet_test(st, n)
    for ty, tx, _, w in _inner_taps(S, zone, sheet, v):
        acc += w[..., None] * L[ty, tx]
        wsum += w
    B = gather_blocks(E, S, zone)
    for j in range(-blocks, blocks + 1):
        for i in range(-blocks, blocks + 1):
            if max(abs(i), abs(j)) <= 1:
                continue
            cy, cx, same, d = _block_tap(B, S, zone, sheet, i, j)
            area = B["area"][cy, cx]
            vb = v + B["spread"][cy, cx]
            w = same * (v / vb) * np.exp(-0.5 * (d * d).sum(-1) / vb)
            dl = B["lit_point"][cy, cx] - x
            vl = v + B["lit_spread"][cy, cx]
            wl = same * (v / vl) * np.exp(-0.5 * (dl * dl).sum(-1) / vl)
            e = B["light"][cy, cx]
            acc[..., :3] += wl[..., None] * e[..., :3]
            acc[..., 3] += w * e[..., 3]
            wsum += w * area
    out = np.where(wsum[..., None] > 0, acc / np.maximum(wsum, 1e-300)[..., None], E)
    return out


# -- the split sum (issue 27): light-independent weights once, the light's sum on every light move --------
# The gather's weights depend on the surface, the zones, the stretch, v and the reach only. They are made
# once (deon_gather_weights.frag) and packed 4 to a texel: the 36 inner texels' w / s (< 0: past a mesh
# border, its light taken at PAST_BORDER_SHARE), then each outer block's w A_b / s (A_b its area; -1: not
# summed: another zone, no area, or across air), with s = |area at x| (1 when 0) so the weights stay near 1.
# A light move then fetches E, the blocks' light and these weights and sums (deon_gather_sum.frag).
KEPT_RINGS = 3  # block rings whose weights are kept; a wider reach computes the rest in the sum (deon_gather_sum LIVE)
WEIGHT_DTYPE = np.float16  # RGBA16F: 2^-11 relative per weight (measured against the ruler: notes/deon_light_move.md)
HALF_MAX = 65504.0
NOT_SUMMED = -1.0


def block_offsets(blocks: int) -> list[tuple[int, int]]:
    """The outer blocks (i, j) in the order of the split sum's weights: ring by ring from ring 2 (a ring's
    index does not depend on the reach), each ring's rows j then i; the inner 3 x 3 left out."""
    return [(i, j) for ring in range(2, blocks + 1) for j in range(-ring, ring + 1) for i in range(-ring, ring + 1)
            if max(abs(i), abs(j)) == ring]


def weight_count(blocks: int) -> int:
    """Weights per texel: 36 inner texels and the outer blocks."""
    return 36 + len(block_offsets(blocks))


def weight_textures(blocks: int) -> int:
    """RGBA textures holding weight_count(blocks) weights."""
    return -(-weight_count(blocks) // 4)


def gather_weights(surface: ArrayLike, zone: ArrayLike, stretch: ArrayLike, v: float, blocks: int = GATHER_BLOCKS,
                   dtype: Any = WEIGHT_DTYPE) -> FloatArray:
    """deon_gather_weights.frag at every texel: (n, n, 4 * weight_textures(blocks)) in float64, the kept
    ones (rings <= KEPT_RINGS) rounded through ``dtype`` (None: not rounded); past KEPT_RINGS the weights
    deon_gather_sum.frag computes itself (LIVE). The same Gaussians, zone and sheet tests as surface_gather."""
    S = np.asarray(surface, np.float64)
    st = np.asarray(stretch, np.float64)
    zone = np.asarray(zone, np.float64)
    n = S.shape[0]
    v = max(float(v), 1e-30)
    s = np.where(np.abs(S[..., 3]) > 0, np.abs(S[..., 3]), 1.0)
    sheet = _sheet_test(st, n)
    out = np.zeros((n, n, 4 * weight_textures(blocks)))
    k = 0
    for _, _, t, w in _inner_taps(S, zone, sheet, v):
        out[..., k] = np.where(t[..., 3] < 0, -1.0, 1.0) * np.minimum(w / s, HALF_MAX)
        k += 1
    B = gather_blocks(np.zeros(S.shape), S, zone)
    for i, j in block_offsets(blocks):
        cy, cx, same, d = _block_tap(B, S, zone, sheet, i, j)
        area = B["area"][cy, cx]
        vb = v + B["spread"][cy, cx]
        w = (v / vb) * np.exp(-0.5 * (d * d).sum(-1) / vb)
        out[..., k] = np.where(same > 0, np.minimum(w * area / s, HALF_MAX), NOT_SUMMED)
        k += 1
    if dtype is None:
        return out
    k = weight_count(min(blocks, KEPT_RINGS))  # the kept ones are stored so; the rest is computed in the sum
    out[..., :k] = out[..., :k].astype(dtype).astype(np.float64)
    return out


def gather_sum(E: ArrayLike, surface: ArrayLike, weights: ArrayLike, v: float, blocks: int = GATHER_BLOCKS,
               lit_ring: int | None = None) -> FloatArray:
    """deon_gather_sum.frag at every texel (n, n, 4): surface_gather's sum from gather_weights' weights, E
    and its blocks' light (gather_blocks: the summed light, its mean point and spread; the mean thickness).
    ``lit_ring`` (LIT_RING; None: every ring): the rings past it take their light at the area's mean point
    (the weight of their thickness) instead of the light's own, which only surface_gather's rings <= it do."""
    E = np.asarray(E, np.float64)
    S = np.asarray(surface, np.float64)
    W = np.asarray(weights, np.float64)
    n = E.shape[0]
    v = max(float(v), 1e-30)
    L = np.array(E)
    x = S[..., :3]
    s = np.where(np.abs(S[..., 3]) > 0, np.abs(S[..., 3]), 1.0)
    yy, xx = np.mgrid[0:n, 0:n]
    by, bx = yy >> 1, xx >> 1
    acc = np.zeros((n, n, 4))
    wsum = np.zeros((n, n))
    k = 0
    for j in range(-2, 4):
        for i in range(-2, 4):
            ty, tx = np.clip(2 * by + j, 0, n - 1), np.clip(2 * bx + i, 0, n - 1)
            w = W[..., k]
            e = L[ty, tx]
            acc[..., :3] += np.abs(w)[..., None] * np.where((w > 0)[..., None], e[..., :3], PAST_BORDER_SHARE * e[..., :3])
            acc[..., 3] += np.abs(w) * e[..., 3]
            wsum += np.abs(w)
            k += 1
    B = gather_blocks(E, S, np.ones(S.shape[:2]))
    h = B["area"].shape[0]
    thick = B["light"][..., 3] / np.maximum(B["area"], 1e-30)  # the mean thickness (MEAN_THICKNESS)
    lit = np.zeros((n, n, 3))
    for i, j in block_offsets(blocks):
        cy, cx = np.clip(by + j, 0, h - 1), np.clip(bx + i, 0, h - 1)
        w = W[..., k]
        wa = np.maximum(w, 0.0)
        acc[..., 3] += wa * thick[cy, cx]
        wsum += wa
        if lit_ring is not None and max(abs(i), abs(j)) > lit_ring:  # FLAT: the mean light at W
            acc[..., :3] += wa[..., None] * B["light"][cy, cx, :3] / np.maximum(B["area"][cy, cx], 1e-30)[..., None]
            k += 1
            continue
        dl = B["lit_point"][cy, cx] - x
        vl = v + B["lit_spread"][cy, cx]
        wl = (w >= 0) * (v / vl) * np.exp(-0.5 * (dl * dl).sum(-1) / vl)
        lit += wl[..., None] * B["light"][cy, cx, :3]
        k += 1
    acc[..., :3] += lit / s[..., None]
    return np.where(wsum[..., None] > 0, acc / np.maximum(wsum, 1e-300)[..., None], E)
