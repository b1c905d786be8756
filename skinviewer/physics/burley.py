"""Burley normalized diffusion sampled in screen space: Golubev 2018 (Unity HDRP) and the thesis's
contrast-driven two-level sampling ("Golubev Plus", seed 001 ch. 4). Plain numpy; the GLSL in
``shaders/lib/burley.glsl`` must agree with it (tests compare them).

Spec: ../shared/design/screen_space.md §1.4, §5, §7, §12.4, §12.6, §13. Units: radii in mm, ``x = r/d``
(= s r) in units of the shape distance d.

- Profile and CDF: seed 001 eq. 2.83, eq. 3.9 (``profiles.burley_normalized`` / ``burley_cdf``).
- Inverse CDF: eq. 3.12-3.13 **corrected** (spec E7: numerator 1 + G^(-1/3) + G^(+1/3), the printed
  G^(-1/3) twice is not an inverse).
- Sample tables (spec §5.3 step 4, §7.6): stratified u_i = (i + 0.5)/n, x_i = P^-1(u_i),
  rcpPdfUnit_i = 8 pi / (e^-x + e^-x/3) (so 1/pdf = rcpPdfUnit * d in polar measure),
  phi_i = 2 pi frac(i / golden ratio) (golden-angle directions), rotated per pixel by a stable hash.
- Filter radius: P^-1(0.997) d = 16.5644 d (spec §5.3).
- Two-level sampling: Algorithm 1 (spec §7.5-7.6) with per-channel contrast C = |L_in - L_out| / (L_in + L_out)
  (seed 001 eq. 4.1) between an inner and an outer ring of the base samples.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from skinviewer.physics.arrays import BoolArray, Float32Array, FloatArray, IntArray
from skinviewer.physics.profiles import (
    burley_cdf,
    burley_inverse_cdf,
    burley_normalized,
    burley_scale,
)

GOLDEN_RATIO = 1.618033988749895
GOLDEN_ANGLE = 2.0 * math.pi * (2.0 - GOLDEN_RATIO)  # 2.399963229728653 rad
FILTER_CDF = 0.997  # HDRP: the filter radius is the 0.997 point of the CDF ("three sigma")
PIXELS_PER_SAMPLE = 4.0  # HDRP SSS_PIXELS_PER_SAMPLE: the sample budget follows the kernel's pixel area
EXTRA_PHASE = 0.5 * GOLDEN_ANGLE  # spec §7.6 [GAP]: the extra set's directions are turned by half a golden angle
S_MAX = float(2 ** 24)  # HDRP clamps S = 1/d to 2^24


# ---------------------------------------------------------------------------------------------
# profile, CDF, inverse

def cdf(x: ArrayLike) -> FloatArray:
    """P(x) = 1 - e^-x/4 - 3 e^(-x/3)/4, seed 001 eq. 3.9 with x = s r."""
    return burley_cdf(np.asarray(x, dtype=np.float64), 1.0)


def inverse_cdf(p: ArrayLike, printed: bool = False) -> FloatArray:
    """x = s r with P(x) = p, eq. 3.12-3.13 (u = 1 - p). ``printed=True``: the seed's misprint (wrong)."""
    return burley_inverse_cdf(1.0 - np.asarray(p, dtype=np.float64), 1.0, printed=printed)


FILTER_RADIUS_UNIT = float(inverse_cdf(FILTER_CDF))  # 16.5644 (x units: multiply by d for mm)


def polar_pdf_unit(x: ArrayLike) -> FloatArray:
    """p(r, phi) d = (e^-x + e^-x/3) / (8 pi): the pdf of (r, phi) per unit r/d and radian."""
    xa = np.asarray(x, dtype=np.float64)
    return (np.exp(-xa) + np.exp(-xa / 3.0)) / (8.0 * math.pi)


def rcp_pdf_unit(x: ArrayLike) -> FloatArray:
    """8 pi / (e^-x + e^-x/3): 1/pdf in polar measure divided by d (spec §5.3 step 4)."""
    return 1.0 / polar_pdf_unit(x)


# ---------------------------------------------------------------------------------------------
# sample tables

@dataclass(frozen=True)
class SampleSet:
    """One stratified set of n Burley samples (x in units of d)."""
    n: int
    x: FloatArray  # (n,) radii r/d, ascending
    rcp_pdf: FloatArray  # (n,) rcpPdfUnit
    phi: FloatArray  # (n,) directions, radians
    inner: BoolArray  # (n,) inner ring (spec §7.3)

    @property
    def cos_sin(self) -> FloatArray:
        return np.stack([np.cos(self.phi), np.sin(self.phi)], axis=-1)


SPLITS = ("half-radius", "area-third", "equal-count")


def ring_flags(x: ArrayLike, split: str = "half-radius") -> BoolArray:
    """Inner-ring flags of a base set (spec §7.3): ``half-radius`` r <= R/2 (thesis: inner:outer area 1:3),
    ``area-third`` r <= R/sqrt(3) (the other reading of 1:3), ``equal-count`` the first half of the samples
    by radius (a variant: the outer mean then rests on n/2 samples instead of 2)."""
    xa = np.asarray(x, dtype=np.float64)
    if split == "half-radius":
        return xa <= 0.5 * float(xa.max())
    if split == "area-third":
        return xa <= float(xa.max()) / math.sqrt(3.0)
    if split == "equal-count":
        return np.arange(len(xa)) < (len(xa) + 1) // 2
    raise ValueError(f"unknown ring split {split!r}; known: {', '.join(SPLITS)}")


def nested_sets(n_base: int, n_total: int, split: str = "half-radius") -> tuple[SampleSet, SampleSet]:
    """A base set that is a subset of Golubev's n_total-sample set, and the rest of that set (a variant of
    §7.6: the extra level *completes* one stratified set instead of pooling two unrelated ones). With
    m = n_total / n_base odd, entries m k + (m - 1)/2 of the n_total set have u = (k + 0.5)/n_base: the
    base set keeps Golubev's n_base radii (with the directions of the bigger set)."""
    m, r = divmod(n_total, n_base)
    if r or m % 2 == 0 or m < 3:
        raise ValueError(f"a nested base needs n_total / n_base odd and >= 3 (got {n_total}/{n_base})")
    full = sample_set(n_total)
    pick = np.arange(n_base) * m + (m - 1) // 2
    rest = np.setdiff1d(np.arange(n_total), pick)
    base = SampleSet(n_base, full.x[pick], full.rcp_pdf[pick], full.phi[pick], ring_flags(full.x[pick], split))
    extra = SampleSet(len(rest), full.x[rest], full.rcp_pdf[rest], full.phi[rest], np.zeros(len(rest), bool))
    return base, extra


def sample_set(n: int, phase: float = 0.0, split: str = "half-radius") -> SampleSet:
    """Golubev's table of n samples: u_i = (i + 0.5)/n, x_i = P^-1(u_i), phi_i = 2 pi frac(i/golden) + phase."""
    if not 1 <= n <= 1024:
        raise ValueError(f"sample count must be in 1..1024 (got {n})")
    i = np.arange(n, dtype=np.float64)
    u = (i + 0.5) / n
    x = inverse_cdf(u)
    phi = 2.0 * math.pi * np.mod(i / GOLDEN_RATIO, 1.0) + phase
    return SampleSet(n, x, rcp_pdf_unit(x), phi, ring_flags(x, split))


# ---------------------------------------------------------------------------------------------
# albedo / mean free path -> shape (seed 001 eq. 2.83-2.89, §3.4)

FITS = ("searchlight-dmfp", "searchlight-mfp", "diffuse-transmission", "direct")


def shape_distance(albedo: ArrayLike, mfp: ArrayLike, fit: str = "searchlight-dmfp") -> FloatArray:
    """Per-channel shape distance d = l / s(A) in mm (eq. 2.84 with Christensen's fits 2.86 / 2.88 / 2.89);
    ``direct``: HDRP-new's scattering distance, d = mfp (the fit is bypassed)."""
    A = np.asarray(albedo, dtype=np.float64)
    l = np.asarray(mfp, dtype=np.float64)
    if np.any(l <= 0) or not np.all(np.isfinite(l)):
        raise ValueError("mean free path must be finite and > 0 mm")
    if fit == "direct":
        out: FloatArray = np.broadcast_to(l, np.broadcast_shapes(A.shape, l.shape)).copy()
        return out
    return l / burley_scale(A, fit)


@dataclass(frozen=True)
class Profile:
    """What the blur needs per profile: S_c = 1/d_c (1/mm), d = max d_c, the filter radius in mm."""
    d_rgb: FloatArray

    @property
    def S(self) -> FloatArray:
        return np.minimum(1.0 / np.maximum(self.d_rgb, 1.0 / S_MAX), S_MAX)

    @property
    def d(self) -> float:
        return float(np.max(self.d_rgb))

    @property
    def filter_radius(self) -> float:
        return FILTER_RADIUS_UNIT * self.d


def profile(albedo: ArrayLike, mfp: ArrayLike, fit: str = "searchlight-dmfp", scale: float = 1.0) -> Profile:
    return Profile(shape_distance(albedo, mfp, fit) * float(scale))


PROFILE_FIELDS = ("albedo", "mfp", "fit", "scale")  # the fields of a `burley` settings section a profile needs


def profile_of_section(b: Any) -> Profile:
    """The profile of a ``burley`` settings section (albedo, mfp, fit, scale)."""
    return profile(b.albedo, b.mfp, b.fit, b.scale)


# ---------------------------------------------------------------------------------------------
# transmission (spec §5.4, HDRP ComputeTransmittanceDisney)

def transmittance(t: ArrayLike, S: ArrayLike, A: ArrayLike = 1.0) -> FloatArray:
    """T(t) = int 2 pi r A R(sqrt(r^2 + t^2)) dr = (A/4)(e^(-S t) + 3 e^(-S t/3)), t in mm, per channel."""
    ta = np.maximum(np.asarray(t, dtype=np.float64), 0.0)
    Sa = np.asarray(S, dtype=np.float64)
    return 0.25 * np.asarray(A, dtype=np.float64) * (np.exp(-Sa * ta) + 3.0 * np.exp(-Sa * ta / 3.0))


def transmittance_thick(t_baked: ArrayLike, t_shadow: ArrayLike, S: ArrayLike, A: ArrayLike = 1.0) -> FloatArray:
    """Thick ("regular") mode: T(t_baked) e^(-S dt/3), dt = max(0, t_shadow - t_baked) (spec §5.4)."""
    dt = np.maximum(np.asarray(t_shadow, dtype=np.float64) - np.asarray(t_baked, dtype=np.float64), 0.0)
    return transmittance(t_baked, S, A) * np.exp(-np.asarray(S, dtype=np.float64) * dt / 3.0)


def transmittance_numeric(t: float, S: float, A: float = 1.0) -> float:
    """The defining integral, by quadrature (for tests)."""
    from scipy.integrate import quad
    d = 1.0 / S
    f = lambda r: 2.0 * math.pi * r * A * float(burley_normalized(math.hypot(r, t), d))
    return float(quad(f, 0.0, np.inf, limit=400, epsabs=1e-12)[0])


# ---------------------------------------------------------------------------------------------
# per-pixel rotation: the GLSL hash, bit-exact in uint32

def pcg_hash(v: ArrayLike) -> NDArray[np.uint32]:
    """PCG-RXS-M-XS 32-bit hash (Jarzynski & Olano 2020), as in shaders/lib/burley.glsl."""
    with np.errstate(over="ignore"):
        va = np.asarray(v, dtype=np.uint32)
        state = va * np.uint32(747796405) + np.uint32(2891336453)
        word = ((state >> ((state >> np.uint32(28)) + np.uint32(4))) ^ state) * np.uint32(277803737)
        out: NDArray[np.uint32] = (word >> np.uint32(22)) ^ word
        return out


def rotation_phase(px: ArrayLike, py: ArrayLike, z: ArrayLike, seed: int = 0) -> Float32Array:
    """psi = 2 pi hash(x, y, bits of floor(linear depth, mm)) / 2^32, float32 like the GLSL (stable
    while the camera and scene are static, spec §5.3 step 4; whole mm, so that the depth's last bits,
    which differ between GPUs, do not re-roll the rotation)."""
    zb = np.floor(np.asarray(z, dtype=np.float32)).astype(np.float32).view(np.uint32)
    with np.errstate(over="ignore"):
        h = pcg_hash(np.asarray(px, np.uint32) + pcg_hash(np.asarray(py, np.uint32) + pcg_hash(zb + np.uint32(seed))))
    out: Float32Array = np.float32(6.2831855) * (h.astype(np.float32) * np.float32(2.3283064e-10))
    return out


# ---------------------------------------------------------------------------------------------
# the per-pixel algorithm on an image (spec §5.3, §7.5-7.6)

CONTRASTS = ("rings", "minmax")


@dataclass
class Sampling:
    """How a pixel spends its samples.

    levels: sample-set sizes; level 0 is the base set, each further level is taken only when the contrast
      of the samples so far exceeds ``cutoffs[k-1]`` in any channel (Algorithm 1 with len(levels) == 2;
      Golubev when len(levels) == 1). A pooled Golubev estimator is ``levels=(12, 10)`` with cutoffs (-1,).
    cutoffs: per level transition, a scalar or an RGB triple (trigger iff C_c > cutoff_c for any c).
    split: ring split of the base set (``ring_flags``); contrast: ``rings`` = eq. 4.1 between the ring means
      of the base samples, ``minmax`` = (max - min)/(max + min) over the base samples (per channel).
    budget: HDRP's adaptive count n <= floor(area / 4 px) (spec §5.3 step 3); the pixel cutoff
      (floor(area/4) < 1 -> no blur) always applies.
    """
    levels: tuple[int, ...] = (22,)
    cutoffs: tuple[float | tuple[float, ...], ...] = ()  # each a scalar or an RGB triple
    split: str = "half-radius"
    contrast: str = "rings"
    budget: bool = False
    nested: bool = False  # two levels that complete one stratified set of levels[0] + levels[1] (nested_sets)
    seed: int = 0  # added to the rotation hash (a decorrelated reference image)
    wide_px: float = 1e30  # kernels at least this wide (filter radius, px) scale the cutoffs by wide_scale
    wide_scale: float = 1.0

    def __post_init__(self) -> None:
        if len(self.cutoffs) != len(self.levels) - 1:
            raise ValueError("one cutoff per extra level")
        if self.contrast not in CONTRASTS:
            raise ValueError(f"unknown contrast {self.contrast!r}")
        ring_flags(np.ones(2), self.split)

    def sets(self) -> list[SampleSet]:
        if self.nested:
            if len(self.levels) != 2:
                raise ValueError("nested sampling has exactly two levels")
            return list(nested_sets(self.levels[0], sum(self.levels), self.split))
        return [sample_set(n, EXTRA_PHASE * k, self.split) for k, n in enumerate(self.levels)]

    @property
    def max_samples(self) -> int:
        return int(sum(self.levels))


@dataclass
class Result:
    out: FloatArray  # (H, W, 3) blurred irradiance (non-SSS and skipped pixels: the input)
    count: IntArray  # (H, W) samples taken
    level: IntArray  # (H, W) levels taken beyond the base (0: base only)
    skipped: BoolArray  # (H, W) SSS pixels under the pixel cutoff
    contrast: FloatArray | None = field(default=None)  # (H, W, 3) base contrast (nan where not computed)


def pixel_scale(z_mm: FloatArray, proj_scale: float) -> FloatArray:
    """Pixels per mm at linear depth z (mm): proj[1][1] * height / 2 / z (a pinhole camera)."""
    return proj_scale / np.maximum(z_mm, 1e-6)


def blur(E: ArrayLike, z: FloatArray, mask: ArrayLike, prof: Profile, proj_scale: float,
         sampling: Sampling) -> Result:
    """The per-pixel algorithm on an image, row 0 at the bottom like a GL texture.

    E (H, W, 3) diffuse irradiance, z (H, W) linear depth in mm, mask (H, W) SSS tag (> 0.5).
    Float64 except the rotation phase and the tables (float32 like the GLSL)."""
    Ea = np.asarray(E, dtype=np.float64)
    H, W = z.shape
    sss = np.asarray(mask) > 0.5
    z32 = np.asarray(z, dtype=np.float32)
    ys, xs = np.mgrid[0:H, 0:W]
    psi = rotation_phase(xs, ys, z32, sampling.seed).astype(np.float64)
    cpsi, spsi = np.cos(psi), np.sin(psi)
    ppm = pixel_scale(z32.astype(np.float64), proj_scale)
    d = prof.d
    S = prof.S
    area = math.pi * (prof.filter_radius * ppm) ** 2
    n_avail = np.floor(area / PIXELS_PER_SAMPLE)
    active = sss & (n_avail >= 1)
    skipped = sss & ~active
    acc = np.zeros((H, W, 3))
    wsum = np.zeros((H, W, 3))
    count = np.zeros((H, W), np.int64)
    level = np.zeros((H, W), np.int64)
    sets = sampling.sets()
    n0 = sampling.levels[0]
    if sampling.budget:
        # fewer samples than the base set: a runtime set of n_avail samples, no further level
        short = active & (n_avail < n0)
        full = active & ~short
        multi = full & (n_avail >= sampling.max_samples) if len(sets) > 1 else full & False
    else:
        short = np.zeros_like(active)
        full = active
        multi = active if len(sets) > 1 else active & False
    zc = z32.astype(np.float64)

    def take(m: BoolArray, xk: np.float64, rcp: np.float64, cs: FloatArray) -> tuple[BoolArray, FloatArray]:
        """One sample at every pixel of mask m; returns the validity mask and the sampled E."""
        r = xk * d
        dx = cs[..., 0] * cpsi - cs[..., 1] * spsi
        dy = cs[..., 1] * cpsi + cs[..., 0] * spsi
        ox = np.floor(ppm * r * dx + 0.5).astype(np.int64)
        oy = np.floor(ppm * r * dy + 0.5).astype(np.int64)
        sx, sy = xs + ox, ys + oy
        inside = (sx >= 0) & (sx < W) & (sy >= 0) & (sy < H)
        sxc, syc = np.clip(sx, 0, W - 1), np.clip(sy, 0, H - 1)
        valid = m & inside & sss[syc, sxc]
        Ei = Ea[syc, sxc]
        dz = zc[syc, sxc] - zc
        rp = np.sqrt(r * r + dz * dz)[..., None]
        w = S / (8.0 * math.pi) * (np.exp(-S * rp) + np.exp(-S * rp / 3.0)) * np.asarray(rcp * d)[..., None]
        w = np.where(valid[..., None], w, 0.0)
        acc[...] += w * Ei
        wsum[...] += w
        count[m] += 1
        return valid, Ei

    # level 0 (full sets) with ring / min-max statistics
    base = sets[0]
    in_sum = np.zeros((H, W, 3)); out_sum = np.zeros((H, W, 3))
    n_in = np.zeros((H, W)); n_out = np.zeros((H, W))
    lo = np.full((H, W, 3), np.inf); hi = np.full((H, W, 3), -np.inf)
    for i in range(base.n):
        valid, Ei = take(full, base.x[i], base.rcp_pdf[i], base.cos_sin[i])
        v3 = valid[..., None]
        if base.inner[i]:
            in_sum += np.where(v3, Ei, 0.0); n_in += valid
        else:
            out_sum += np.where(v3, Ei, 0.0); n_out += valid
        lo = np.where(v3, np.minimum(lo, Ei), lo)
        hi = np.where(v3, np.maximum(hi, Ei), hi)
    contrast = np.full((H, W, 3), np.nan)
    if len(sets) > 1:
        C = contrast_of(sampling.contrast, in_sum, out_sum, n_in, n_out, lo, hi)
        contrast = np.where(multi[..., None], C, np.nan)
        scale = np.where(prof.filter_radius * ppm >= sampling.wide_px, sampling.wide_scale, 1.0)[..., None]
        go = multi & np.any(C > np.asarray(sampling.cutoffs[0], dtype=np.float64) * scale, axis=-1)
        for k, s in enumerate(sets[1:], start=1):
            for j in range(s.n):
                valid, Ei = take(go, s.x[j], s.rcp_pdf[j], s.cos_sin[j])
                if sampling.contrast == "minmax":
                    v3 = valid[..., None]
                    lo = np.where(v3, np.minimum(lo, Ei), lo)
                    hi = np.where(v3, np.maximum(hi, Ei), hi)
            level[go] = k
            if k < len(sets) - 1:
                # a further level is decided from the min/max of every sample so far (rings: base only)
                C2 = contrast_of(sampling.contrast, in_sum, out_sum, n_in, n_out, lo, hi)
                go = go & np.any(C2 > np.asarray(sampling.cutoffs[k], dtype=np.float64) * scale, axis=-1)
    # runtime sets (budget): n_avail samples evaluated per pixel
    if short.any():
        for n in np.unique(n_avail[short]).astype(int):
            m = short & (n_avail == n)
            s = sample_set(n)
            for i in range(n):
                take(m, s.x[i], s.rcp_pdf[i], s.cos_sin[i])
    out = Ea.copy()
    blurred = acc / np.maximum(wsum, np.finfo(np.float32).tiny)
    out[active] = blurred[active]
    return Result(out, count, level, skipped, contrast)


def contrast_of(kind: str, in_sum: FloatArray, out_sum: FloatArray, n_in: FloatArray, n_out: FloatArray,
                lo: FloatArray, hi: FloatArray) -> FloatArray:
    """Per-channel contrast (seed 001 eq. 4.1, spec §7.6 step 3; C = 0 for an empty ring)."""
    if kind == "rings":
        L_in = in_sum / np.maximum(n_in, 1)[..., None]
        L_out = out_sum / np.maximum(n_out, 1)[..., None]
        C = np.abs(L_in - L_out) / np.maximum(L_in + L_out, 1e-6)
        ok = ((n_in > 0) & (n_out > 0))[..., None]
    else:
        ok = np.isfinite(lo) & np.isfinite(hi)
        lo, hi = np.where(ok, lo, 0.0), np.where(ok, hi, 0.0)
        C = (hi - lo) / np.maximum(hi + lo, 1e-6)
    return np.where(ok, np.nan_to_num(C), 0.0)


# ---------------------------------------------------------------------------------------------
# analytic references (spec T4.3, T4.4)

def edge_response(t: ArrayLike) -> FloatArray:
    """Fraction of the profile's mass on the lit side of a straight edge at signed distance t (units of d,
    positive = inside the lit half-plane): 1/2 + int_0^t LSF, LSF(x) = (K0(|x|) + K0(|x|/3)) / (4 pi)
    (spec T4.3)."""
    from scipy.integrate import quad
    from scipy.special import k0

    def one(tt: float) -> float:
        if tt == 0:
            return 0.5
        a = abs(tt)
        # int_0^a K0(x) dx + int_0^a K0(x/3) dx = int_0^a K0 + 3 int_0^(a/3) K0
        I = quad(k0, 0.0, a, limit=200)[0] + 3.0 * quad(k0, 0.0, a / 3.0, limit=200)[0]
        v = I / (4.0 * math.pi)
        return 0.5 + math.copysign(v, tt)

    out: FloatArray = np.vectorize(one, otypes=[np.float64])(np.asarray(t, dtype=np.float64))
    return out


def samples_saved(total: float, golubev_total: float) -> float:
    """1 - samples / samples of the reference (Table 4.1's 'sample reduction')."""
    return 1.0 - total / max(golubev_total, 1e-30)
