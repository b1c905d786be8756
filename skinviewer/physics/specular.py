"""Kelemen/Szirmay-Kalos specular (seed 000 eq. 14-16; seed 002 listings 14-1..14-3), the Beckmann
lookup texture (listing 14-2) and the rho_dt energy-conservation table (seed 000 eq. 30-31).
numpy, float64, vectorised; ``shaders/lib/kelemen.glsl`` is the GLSL twin (same guards, same results).

BRDF vs. cosine (eq. 16 vs. listing 14-3)
    ``ks_brdf``     f_r(L, V) = rho_s * P_H(N.H) * F(H.V) / (h.h),  h = L + V unnormalised (eq. 16 with
                    rho_s folded in). Symmetric in L and V (H, H.V = H.L and h.h all are): reciprocal.
    ``ks_specular`` f_r * max(N.L, 0): listing 14-3's ``result = ndotl * rho_s * frSpec`` ("BRDF *
                    dot(N,L) * rho_s"). This is what a light contributes; it is *not* reciprocal.
    rho_dt (eq. 30) integrates f_r(w_o, L) (w_o.N) dw_o = ks_specular(N, w_o, L) over w_o.

Normalisation: P_H is listing 14-2's PHBeckmann / eq. 15, exp(-tan^2/m^2) / (m^2 cos^4), *without* the
1/pi of the normalised Beckmann NDF D, so f_r here is pi times the energy-normalised KS BRDF; rho_s
absorbs the factor (both seeds agree; rho_dt integrates the same f_r that is rendered, so the energy
the specular takes is exactly the energy the diffuse loses).

Guards ("no NaN, no Inf, ever"), identical in GLSL:
    m is clamped to ``M_MIN`` = 1e-3 (m -> 0 is a delta; 1/m^2 = 1e6 bounds P_H);
    tan^2 = |N x H|^2 / (N.H)^2 (no acos/tan: finite at 90 deg, no cancellation in 1 - cos^2);
    N.H <= 0 -> P_H = 0;  N.L <= 0 -> 0;  h.h < ``HH_EPS`` (L = -V, H undefined) -> 0;
    zero / unnormalised vectors are normalised safely; a zero N, L or V -> 0 specular;
    Schlick's base 1 - H.V is clamped to [0, 1] (H.V <= 0 -> F = 1), f0 to [0, 1], rho_s to >= 0.
    Hence ks_specular <= 10 * 1e6 / 1e-6 = 1e13 for rho_s <= 10: finite in float32 even x 1e5.

Texture layouts (both tables: row index = m, column index = the cosine; upload as R32F,
LINEAR filtering, CLAMP_TO_EDGE on both axes -- see ``upload_table``; sample with
``texture(tex, vec2(cosine, m))``). Texel-centre mapping as a screen-aligned-quad precompute
(listing 14-2) produces: texel (row j, column i) holds the value at
    x = (i + 0.5) / width   (N.H for the Beckmann LUT, cos(theta) for rho_dt),
    y = (j + 0.5) / height  (m).
``sample_bilinear`` reproduces the GPU lookup (inputs outside the outer texel centres clamp to them).
numpy row 0 is uploaded first, i.e. at texture y = 0 (moderngl/GL order): no flip.

rho_dt: quadrature error < 2e-5 * rho_s (vs. a 1500 x 200 rule and the literal eq. 31 brute force).
Bilinear lookup of the default 32 x 32 table vs. direct rho_dt (f0 0.028, rho_s 0.18): <= 1.2e-3 for
cos >= 0.2, 6e-3 for cos >= 0.1, up to ~0.1 for cos < 0.05 with m < 0.1 (steep; N.L ~ 0 there).
By reciprocity the same table serves eq. 34's outgoing term with cos = N.V.
"""
from __future__ import annotations

import functools
from collections.abc import Mapping
from typing import TYPE_CHECKING, Protocol

import numpy as np
from numpy.typing import ArrayLike

from skinviewer.ground.constants import REGIONS
from skinviewer.physics.arrays import BoolArray, Float32Array, FloatArray

if TYPE_CHECKING:
    import moderngl

M_MIN = 1e-3  # roughness clamp: m -> 0 is a delta distribution
HH_EPS = 1e-6  # |L+V|^2 below this (L, V within 0.06 deg of opposite): H undefined -> 0 specular
F0_SKIN = 0.028  # seed 002 §14.3 (IOR 1.4)

# Measured at size 512 (asserted in tests/test_specular.py): relative error of the LUT specular vs.
# direct evaluation for m in [0.15, 0.5], over all N.H in [0, 1] where the specular is >= 1e-3 of its
# peak for that m. The worst case is N.H within half a texel of 1 (listing 14-2's texel-centre grid
# has no texel at N.H = 1; the lookup clamps to N.H = 1 - 0.5/512): 7.96 % at m = 0.15, 1.8 % at
# m = 0.3, 0.4 % at m = 0.5. Everywhere else (N.H <= 1 - 0.5/512, interpolated) it is 4.7e-4.
LUT_512_REL_TOL = 0.085
LUT_512_REL_TOL_INTERIOR = 6e-4


# -- vectors ----------------------------------------------------------------------------------
def _f64(x: ArrayLike) -> FloatArray:
    return np.nan_to_num(np.asarray(x, dtype=np.float64), nan=0.0, posinf=0.0, neginf=0.0)


def safe_normalize(v: ArrayLike) -> FloatArray:
    """v/|v| along the last axis. Vectors with all |v_i| <= 1e-30 become 0 (as in GLSL); NaN/Inf
    components count as 0. Pre-scaled by max|v_i| so huge or tiny vectors neither overflow nor
    underflow."""
    v = _f64(v)
    big = np.max(np.abs(v), axis=-1, keepdims=True)
    ok = big > 1e-30  # as GLSL ks_safe_normalize
    v = np.where(ok, v / np.where(ok, big, 1.0), 0.0)
    n = np.sqrt(np.sum(v * v, axis=-1, keepdims=True))
    return np.where(n > 0.0, v / np.where(n > 0.0, n, 1.0), 0.0)


def _dot(a: FloatArray, b: FloatArray) -> FloatArray:
    out: FloatArray = np.sum(a * b, axis=-1)
    return out


# -- eq. 14-15 --------------------------------------------------------------------------------
def schlick_fresnel(h_dot_v: ArrayLike, f0: ArrayLike) -> FloatArray:
    """Eq. 14 / listing 14-1: (1 - H.V)^5 + f0 (1 - (1 - H.V)^5); base clamped to [0, 1]."""
    b = np.clip(_f64(h_dot_v), 0.0, None)
    b = np.clip(1.0 - b, 0.0, 1.0)
    e = b ** 5
    return e + np.clip(_f64(f0), 0.0, 1.0) * (1.0 - e)


def _beckmann_sc(c: ArrayLike, s2: ArrayLike, m: ArrayLike) -> FloatArray:
    """P_H from cos and sin^2 of the N-H angle: exp(-s2/(c^2 m^2)) / (m^2 c^4); 0 for c <= 0."""
    mm = np.maximum(_f64(m), M_MIN)
    m2 = mm * mm
    c = _f64(c)
    c2 = np.maximum(c * c, 1e-12)
    with np.errstate(over="ignore", under="ignore"):
        val = np.exp(-_f64(s2) / (c2 * m2)) / (m2 * c2 * c2)
    return np.where(c > 0.0, val, 0.0)


def beckmann(n_dot_h: ArrayLike, m: ArrayLike) -> FloatArray:
    """Eq. 15 / listing 14-2 PHBeckmann: exp(-tan^2(a)/m^2) / (m^2 cos^4 a), a = acos(N.H), with
    tan^2 = (1 - c^2)/c^2; N.H <= 0 -> 0; m clamped to M_MIN."""
    c = np.minimum(_f64(n_dot_h), 1.0)
    return _beckmann_sc(c, np.maximum(1.0 - c * c, 0.0), m)


# -- eq. 16 / listing 14-3 ---------------------------------------------------------------------
def _half_terms(n: ArrayLike, l: ArrayLike, v: ArrayLike) -> tuple[
        FloatArray, FloatArray, FloatArray, FloatArray, FloatArray, BoolArray, FloatArray, FloatArray, FloatArray]:
    """Normalised N, L, V; N.L; h.h; N.H; |N x H|^2; H.V (H = 0 where h.h < HH_EPS)."""
    n, l, v = safe_normalize(n), safe_normalize(l), safe_normalize(v)
    h = l + v
    hh = _dot(h, h)
    ok = (hh >= HH_EPS) & (_dot(v, v) > 0.5) & (_dot(l, l) > 0.5)  # and neither V nor L was zero
    hn = h / np.sqrt(np.where(ok, hh, 1.0))[..., None]
    hn = np.where(ok[..., None], hn, 0.0)
    x = np.cross(n, hn)
    return n, l, v, _dot(n, l), hh, ok, _dot(n, hn), _dot(x, x), _dot(hn, v)


def ks_brdf(n: ArrayLike, l: ArrayLike, v: ArrayLike, m: ArrayLike, rho_s: ArrayLike, f0: ArrayLike = F0_SKIN) -> FloatArray:
    """The BRDF f_r = rho_s * P_H * F / (h.h) (eq. 16), without any cosine; reciprocal in (l, v).
    n, l, v: (..., 3), any length; m, rho_s, f0 broadcast against (...). Always finite."""
    _, _, _, _, hh, ok, ndoth, s2, hdotv = _half_terms(n, l, v)
    ph = _beckmann_sc(ndoth, s2, m)
    f = schlick_fresnel(hdotv, f0)
    fr = np.maximum(ph * f / np.where(ok, hh, 1.0), 0.0)
    return np.where(ok, fr * np.maximum(_f64(rho_s), 0.0), 0.0)


def ks_specular(n: ArrayLike, l: ArrayLike, v: ArrayLike, m: ArrayLike, rho_s: ArrayLike, f0: ArrayLike = F0_SKIN) -> FloatArray:
    """Listing 14-3 (direct P_H): f_r * max(N.L, 0) -- what one unit light contributes."""
    nl = _dot(safe_normalize(n), safe_normalize(l))
    return np.where(nl > 0.0, ks_brdf(n, l, v, m, rho_s, f0) * np.maximum(nl, 0.0), 0.0)


# -- listing 14-2: the Beckmann texture -------------------------------------------------------
def texel_centres(size: int) -> FloatArray:
    return (np.arange(size, dtype=np.float64) + 0.5) / size


def beckmann_lut(size: int = 512) -> FloatArray:
    """float32 (size, size): [j, i] = 0.5 * PH(N.H = (i+0.5)/size, m = (j+0.5)/size) ** 0.1
    (listing 14-2: tex.x = N.H along columns, tex.y = m along rows; texel centres)."""
    x = texel_centres(size)
    ph = beckmann(x[None, :], x[:, None])
    return (0.5 * ph ** 0.1).astype(np.float32)


def decode_beckmann(tex: ArrayLike) -> FloatArray:
    """Inverse of the encoding (listing 14-3): PH = (2 tex)^10 (negative texels -> 0)."""
    x = np.maximum(2.0 * _f64(tex), 0.0)
    x2 = x * x
    x4 = x2 * x2
    out: FloatArray = x4 * x4 * x2
    return out


def sample_bilinear(table: ArrayLike, x: ArrayLike, y: ArrayLike) -> FloatArray:
    """GPU-style lookup of a (height, width) table at normalised (x, y): GL_LINEAR with
    CLAMP_TO_EDGE, texel centres at (i + 0.5)/width. Full-precision weights (llvmpipe on float
    textures; hardware may quantise weights to 8 bits)."""
    t = np.asarray(table, dtype=np.float64)
    hgt, wid = t.shape
    x, y = np.broadcast_arrays(_f64(x), _f64(y))
    u = np.clip(x, -1.0, 2.0) * wid - 0.5
    w = np.clip(y, -1.0, 2.0) * hgt - 0.5
    i0 = np.floor(u)
    j0 = np.floor(w)
    a = u - i0
    b = w - j0
    i0 = i0.astype(np.int64)
    j0 = j0.astype(np.int64)
    i1 = np.clip(i0 + 1, 0, wid - 1)
    j1 = np.clip(j0 + 1, 0, hgt - 1)
    i0 = np.clip(i0, 0, wid - 1)
    j0 = np.clip(j0, 0, hgt - 1)
    out: FloatArray = ((1 - a) * (1 - b) * t[j0, i0] + a * (1 - b) * t[j0, i1]
                       + (1 - a) * b * t[j1, i0] + a * b * t[j1, i1])
    return out


def ks_specular_lut(n: ArrayLike, l: ArrayLike, v: ArrayLike, m: ArrayLike, rho_s: ArrayLike, f0: ArrayLike, lut: ArrayLike) -> FloatArray:
    """Listing 14-3 exactly (P_H from the Beckmann texture ``lut``), with the direct mode's guards;
    numpy twin of GLSL ``ks_specular_lut``."""
    _, _, _, nl, hh, ok, ndoth, _, hdotv = _half_terms(n, l, v)
    mm = np.maximum(_f64(m), M_MIN)
    ph = decode_beckmann(sample_bilinear(lut, np.clip(ndoth, 0.0, 1.0), mm))
    ph = np.where(ndoth > 0.0, ph, 0.0)
    fr = np.maximum(ph * schlick_fresnel(hdotv, f0) / np.where(ok, hh, 1.0), 0.0)
    return np.where(ok & (nl > 0.0), fr * np.maximum(_f64(rho_s), 0.0) * np.maximum(nl, 0.0), 0.0)


# -- eq. 30-31: rho_dt --------------------------------------------------------------------------
# Eq. 31 integrates over w_o in spherical coordinates about N. We substitute the half vector H
# (theta_h, phi), w_o = 2 (L.H) H - L, dw_o = 4 (L.H) dw_H, h.h = 4 (L.H)^2, and then
# u = tan^2(theta_h)/m^2, s = 1 - exp(-u), for which P_H dw_H = ds dphi / (2 cos theta_h) exactly.
# So  I = int f_r/rho_s (w_o.N) dw_o = int_0^1 ds int dphi F(L.H) (w_o.N) / (2 cos theta_h L.H):
# a bounded integrand whatever m is (the lobe is always spread over s). The horizon w_o.N > 0 is
# cos(phi) > kappa(s), so phi runs exactly over [-phi_max, phi_max] (smooth inside; no kink);
# Gauss-Legendre in s (N_S nodes) and in phi (N_PHI). Error vs. a 1500 x 200 rule: < 2e-5 in I.
# F = e + f0 (1 - e) is linear in f0 and f_r in rho_s, so two tables (for F = e and F = 1) are
# cached and rho_dt(f0, rho_s) = 1 - rho_s ((1 - f0) I_e + f0 I_1) costs nothing per UI change.
N_S = 96
N_PHI = 24


@functools.lru_cache(maxsize=4)
def _gauss01(n: int) -> tuple[FloatArray, FloatArray]:
    x, w = np.polynomial.legendre.leggauss(n)
    return 0.5 * (x + 1.0), 0.5 * w


def _rho_integrals(cos_theta: ArrayLike, m: ArrayLike, n_s: int = N_S, n_phi: int = N_PHI
                   ) -> tuple[FloatArray, FloatArray]:
    """(I_e, I_1) for arrays cos_theta, m of equal shape: int f_r/rho_s cos dw_o with F = e, 1."""
    mu = np.clip(_f64(cos_theta), 0.0, 1.0)[..., None, None]
    mm = np.maximum(_f64(m), M_MIN)[..., None, None]
    s, ws = _gauss01(n_s)
    xp, wp = _gauss01(n_phi)
    t = mm * np.sqrt(-np.log1p(-s))[:, None]  # tan(theta_h), shape (..., n_s, 1)
    ch = 1.0 / np.sqrt(1.0 + t * t)
    sh = t * ch
    sl = np.sqrt(np.maximum(1.0 - mu * mu, 0.0))
    # w_o.N = 2 (L.H) cos theta_h - mu > 0  <=>  cos phi > kappa: integrate phi over [0, phi_max]
    num = mu * (0.5 / ch - ch)
    den = sl * sh
    kappa = np.where(den > 0.0, num / np.where(den > 0.0, den, 1.0), np.where(num > 0.0, 2.0, -2.0))
    phi_max = np.arccos(np.clip(kappa, -1.0, 1.0))
    phi = phi_max * xp  # (..., n_s, n_phi)
    lh = sl * sh * np.cos(phi) + mu * ch  # L.H with L = (sin, 0, cos)
    cos_o = 2.0 * lh * ch - mu
    ok = (lh > 0.0) & (cos_o > 0.0)
    g = np.where(ok, cos_o / (2.0 * ch * np.where(ok, lh, 1.0)), 0.0)
    g = g * (wp * (2.0 * phi_max)) * ws[:, None]  # x2: phi in [-phi_max, phi_max]
    e = np.clip(1.0 - lh, 0.0, 1.0) ** 5
    return np.sum(g * e, axis=(-2, -1)), np.sum(g, axis=(-2, -1))


def rho_dt(cos_theta: ArrayLike, m: ArrayLike, f0: ArrayLike = F0_SKIN, rho_s: ArrayLike = 0.18) -> FloatArray:
    """Eq. 30: 1 - int f_r(w_o, L) (w_o.N) dw_o for cos(theta) = N.L, clamped to [0, 1]; vectorised
    over cos_theta and m (broadcast)."""
    c, mm = np.broadcast_arrays(_f64(cos_theta), _f64(m))
    i_e, i_1 = _rho_integrals(c, mm)
    f0 = np.clip(_f64(f0), 0.0, 1.0)
    out: FloatArray = np.clip(1.0 - np.maximum(_f64(rho_s), 0.0) * ((1.0 - f0) * i_e + f0 * i_1), 0.0, 1.0)
    return out


@functools.lru_cache(maxsize=8)
def _rho_tables(n_cos: int, n_m: int) -> tuple[FloatArray, FloatArray]:
    c = texel_centres(n_cos)[None, :]
    mm = texel_centres(n_m)[:, None]
    cos_b, m_b = np.broadcast_arrays(c, mm)
    i_e, i_1 = _rho_integrals(cos_b, m_b)
    i_e.setflags(write=False)
    i_1.setflags(write=False)
    return i_e, i_1


def rho_dt_table(f0: ArrayLike = F0_SKIN, rho_s: ArrayLike = 0.18, n_cos: int = 32, n_m: int = 32) -> Float32Array:
    """float32 (n_m, n_cos): [j, i] = rho_dt(cos = (i+0.5)/n_cos, m = (j+0.5)/n_m) (texel centres;
    rows = m, columns = cos theta; sample with texture(tex, vec2(cos_theta, m)))."""
    i_e, i_1 = _rho_tables(int(n_cos), int(n_m))
    f0 = float(np.clip(_f64(f0), 0.0, 1.0))
    rho_s = max(float(_f64(rho_s)), 0.0)
    out: Float32Array = np.clip(1.0 - rho_s * ((1.0 - f0) * i_e + f0 * i_1), 0.0, 1.0).astype(np.float32)
    return out


def rho_dt_bruteforce(cos_theta: float, m: float, f0: ArrayLike = F0_SKIN, rho_s: ArrayLike = 0.18,
                      n_theta: int = 1024, n_phi: int = 2048) -> float:
    """Reference for tests: eq. 31 literally, midpoint rule over w_o = (theta, phi) about N with
    ks_specular(N, w_o, L) = f_r (w_o.N), unclamped. Fine enough for m >= ~0.1."""
    mu = float(np.clip(cos_theta, 0.0, 1.0))
    th = (np.arange(n_theta) + 0.5) * (0.5 * np.pi / n_theta)
    ph = (np.arange(n_phi) + 0.5) * (2.0 * np.pi / n_phi)
    st, ct = np.sin(th)[:, None], np.cos(th)[:, None]
    w_o = np.stack(np.broadcast_arrays(st * np.cos(ph), st * np.sin(ph), ct), axis=-1)
    light = np.array([np.sqrt(1.0 - mu * mu), 0.0, mu])
    val = ks_specular(np.array([0.0, 0.0, 1.0]), w_o, light, m, rho_s, f0)
    integral = np.sum(val * st) * (0.5 * np.pi / n_theta) * (2.0 * np.pi / n_phi)
    return 1.0 - float(integral)


def upload_table(ctx: moderngl.Context, table: ArrayLike) -> moderngl.Texture:
    """An R32F texture of a (height, width) table with the sampling the layouts above assume:
    LINEAR filtering, CLAMP_TO_EDGE (moderngl defaults to repeat)."""
    t = np.ascontiguousarray(table, dtype=np.float32)
    tex = ctx.texture((t.shape[1], t.shape[0]), 1, t.tobytes(), dtype="f4")
    tex.repeat_x = False
    tex.repeat_y = False
    import moderngl  # noqa: PLC0415 - only the GPU passes need it

    tex.filter = (moderngl.LINEAR, moderngl.LINEAR)
    return tex


class RegionSpecular(Protocol):
    """One facial region's overrides (None: keep the global value)."""
    @property
    def m(self) -> float | None: ...
    @property
    def rho_s(self) -> float | None: ...


class RegionalSpecular(Protocol):
    """The global roughness and intensity with per-region overrides (the settings' ``specular``)."""
    @property
    def m(self) -> float: ...
    @property
    def rho_s(self) -> float: ...
    @property
    def per_region(self) -> Mapping[str, RegionSpecular]: ...


def per_region_specular(sp: RegionalSpecular) -> tuple[Float32Array, Float32Array]:
    """(m, rho_s) float32 arrays indexed by region ID (ground.constants.REGIONS): Weyrich et al.'s
    per-region values (seed 002 §14.3) from ``sp.per_region``, the global ``sp.m`` / ``sp.rho_s`` where
    a region sets none. The lit passes upload both tables (lib/specular_params.glsl); the ground
    truth indexes them by the mesh's region map."""
    m: Float32Array = np.full(len(REGIONS), sp.m, np.float32)
    rho: Float32Array = np.full(len(REGIONS), sp.rho_s, np.float32)
    for name, rs in sp.per_region.items():
        k = REGIONS.index(name)
        if rs.m is not None:
            m[k] = rs.m
        if rs.rho_s is not None:
            rho[k] = rs.rho_s
    return m, rho
