"""Diffusion profiles R(r) (r in mm, R in 1/mm^2), one value per RGB channel.

Every model is a small frozen object: ``model(r)`` returns an array of shape ``np.shape(r) + (3,)``
(radially symmetric, ``r`` may be any array, negative r is treated as |r|), and
``model.total_reflectance()`` returns the (3,) total diffuse reflectance R_d = 2*pi*int r R(r) dr.
Dipole and multipole also expose ``hankel(k)``: the 2-D Fourier transform
F(k) = 2*pi*int r R(r) J0(k r) dr (so F(0) = R_d), which is how layers combine (seed 001 eq. 2.77-2.82).

Sources (equation numbers refer to ../shared/seeds, see the README there):
  * dipole         seed 001 eq. (2.53)-(2.59), Jensen et al. 2001;
  * multipole      seed 001 eq. (2.60)-(2.69), Donner & Jensen 2005; layers eq. (2.73)-(2.82);
  * Burley         seed 001 eq. (2.83)-(2.89), CDF (3.9), inverse (3.12)-(3.13);
  * Gaussians      seed 000 eq. (20)-(22), seed 002 section 14.4.4.

Where the printed seeds and the mathematics disagree the mathematics is implemented; the printed
form is kept where it can be selected (``printed=True`` / ``form="printed"``):
  * eq. (2.59) / (2.54): z_r = 1/sigma_t' (reduced extinction; the text writes 1/sigma_t).
  * eq. (2.65), (2.67): the prefactor is alpha'/(4 pi) (printed sigma'/(4 pi)); in (2.67) the source
    heights in the numerator are (z + s) like in the distances (2.69), printed z (``form="printed"``).
  * eq. (2.78)-(2.79): the transforms integrate over the whole plane (printed: a disc of radius d).
  * eq. (3.12): x = 3 log((1 + G^(-1/3) + G^(+1/3)) / (4u)); the printed G^(-1/3) twice is not an
    inverse of (3.9) (``burley_inverse_cdf(..., printed=True)``).
  * eq. (3.8) of seed 001 writes 1/(2 pi sigma); with the variance v the unit-integral 2-D Gaussian is
    1/(2 pi v) exp(-r^2/(2v)) (seed 000 eq. 21, seed 002 14.4.4), which ``gaussian`` uses.
"""
from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

from skinviewer.physics.arrays import FloatArray
from skinviewer.physics.diffusion import gaussian as _diffusion_gaussian

FOUR_PI = 4.0 * math.pi

ArrayLike = float | Sequence[float] | np.ndarray


def _rgb(x: ArrayLike, name: str) -> FloatArray:
    a = np.asarray(x, dtype=np.float64)
    if a.ndim == 0:
        a = np.full(3, float(a))
    if a.shape != (3,):
        raise ValueError(f"{name} must be a number or 3 numbers (r,g,b), got shape {a.shape}")
    if not np.all(np.isfinite(a)):
        raise ValueError(f"{name} must be finite")
    return a


def _r(r: ArrayLike) -> FloatArray:
    return np.abs(np.asarray(r, dtype=np.float64))[..., None]  # (..., 1) broadcasts against (3,)


# ---------------------------------------------------------------------------------------------
# boundary terms

def fresnel_diffuse_reflectance(eta: float) -> float:
    """F_dr, seed 001 eq. (2.49), with the rational fits of Jensen 2001 / Egan & Hilgeman 1973."""
    if not (eta > 0 and math.isfinite(eta)):
        raise ValueError("eta must be a positive number")
    if eta >= 1.0:
        return -1.440 / eta**2 + 0.710 / eta + 0.668 + 0.0636 * eta
    return -0.4399 + 0.7099 / eta - 0.3319 / eta**2 + 0.0636 / eta**3


def boundary_A(eta: float) -> float:
    """A = (1 + F_dr) / (1 - F_dr), seed 001 eq. (2.53); eta is the relative index inside/outside."""
    f = fresnel_diffuse_reflectance(eta)
    return (1.0 + f) / (1.0 - f)


# ---------------------------------------------------------------------------------------------
# 2-D Fourier transform of one dipole term (used for the multipole and the layer combination)
#
# f_z(r) = z (1 + s d) exp(-s d) / d^3, d = sqrt(r^2 + z^2), is -d/dz of the point-source field
# exp(-s d)/d whose 2-D transform is 2 pi exp(-|z| q)/q, q = sqrt(s^2 + k^2). Hence
#   F{f_z}(k) = 2 pi sign(z) exp(-|z| q).                     (exact, whole plane)

def _dipole_term(r: FloatArray, z: FloatArray, s: FloatArray) -> FloatArray:
    # written as (z/d) ((1/d + s)/d) e^{-s d}: no overflow for huge r, exact 0 at r = inf
    d = np.hypot(r, z)
    with np.errstate(over="ignore", under="ignore", invalid="ignore", divide="ignore"):
        sd = np.where(s > 0, s * d, 0.0)
        out = (z / d) * ((1.0 / d + s) / d) * np.exp(-sd)
    return np.where(d > 0, np.nan_to_num(out, nan=0.0), 0.0)


def _dipole_term_hat(q: FloatArray, z: FloatArray) -> FloatArray:
    with np.errstate(under="ignore"):
        return 2.0 * math.pi * np.sign(z) * np.exp(-np.abs(z) * q)


@dataclass(frozen=True)
class _Coefficients:
    sigma_s_prime: FloatArray
    sigma_a: FloatArray

    @property
    def sigma_t_prime(self) -> FloatArray:  # eq. (2.35)
        return self.sigma_s_prime + self.sigma_a

    @property
    def alpha_prime(self) -> FloatArray:  # reduced albedo
        return self.sigma_s_prime / self.sigma_t_prime

    @property
    def D(self) -> FloatArray:  # diffusion coefficient 1/(3 sigma_t')
        return 1.0 / (3.0 * self.sigma_t_prime)

    @property
    def sigma_tr(self) -> FloatArray:  # effective transport coefficient sqrt(3 sigma_a sigma_t')
        return np.sqrt(3.0 * self.sigma_a * self.sigma_t_prime)


def _coeffs(sigma_s_prime: ArrayLike, sigma_a: ArrayLike) -> _Coefficients:
    ssp, sa = _rgb(sigma_s_prime, "sigma_s_prime"), _rgb(sigma_a, "sigma_a")
    if np.any(ssp < 0) or np.any(sa < 0):
        raise ValueError("scattering and absorption coefficients must be >= 0")
    if np.any(ssp + sa <= 0):
        raise ValueError("sigma_s' + sigma_a must be > 0 in every channel (an empty medium has no profile)")
    return _Coefficients(ssp, sa)


# ---------------------------------------------------------------------------------------------
# Jensen 2001 dipole

@dataclass(frozen=True)
class Dipole:
    """Jensen et al. 2001 dipole for a semi-infinite medium, seed 001 eq. (2.59).

    R(r) = alpha'/(4 pi) [ z_r (1 + s d_r) e^(-s d_r)/d_r^3 + z_v (1 + s d_v) e^(-s d_v)/d_v^3 ],
    z_r = 1/sigma_t', z_v = z_r + 4 A D, d = sqrt(r^2 + z^2) (eq. 2.58), s = sigma_tr.
    Coefficients in 1/mm, eta = relative index of refraction of the medium.
    """
    sigma_s_prime: FloatArray
    sigma_a: FloatArray
    eta: float = 1.3

    def __init__(self, sigma_s_prime: ArrayLike, sigma_a: ArrayLike, eta: float = 1.3):
        c = _coeffs(sigma_s_prime, sigma_a)
        boundary_A(eta)  # validates eta
        object.__setattr__(self, "sigma_s_prime", c.sigma_s_prime)
        object.__setattr__(self, "sigma_a", c.sigma_a)
        object.__setattr__(self, "eta", float(eta))

    @property
    def c(self) -> _Coefficients:
        return _Coefficients(self.sigma_s_prime, self.sigma_a)

    @property
    def A(self) -> float:
        return boundary_A(self.eta)

    @property
    def z_r(self) -> FloatArray:
        return 1.0 / self.c.sigma_t_prime

    @property
    def z_v(self) -> FloatArray:
        return self.z_r + 4.0 * self.A * self.c.D

    def __call__(self, r: ArrayLike) -> FloatArray:
        c, rr = self.c, _r(r)
        s = c.sigma_tr
        return c.alpha_prime / FOUR_PI * (_dipole_term(rr, self.z_r, s) + _dipole_term(rr, self.z_v, s))

    def hankel(self, k: ArrayLike) -> FloatArray:
        c = self.c
        q = np.sqrt(c.sigma_tr**2 + _r(k) ** 2)
        # the virtual source sits above the surface with negative charge: both terms positive
        return c.alpha_prime / FOUR_PI * (_dipole_term_hat(q, self.z_r) + _dipole_term_hat(q, self.z_v))

    def total_reflectance(self) -> FloatArray:
        """Jensen 2001 closed form R_d = a'/2 (1 + exp(-4/3 A sqrt(3(1-a')))) exp(-sqrt(3(1-a')))."""
        a = self.c.alpha_prime
        t = np.sqrt(3.0 * (1.0 - a))
        return 0.5 * a * (1.0 + np.exp(-4.0 / 3.0 * self.A * t)) * np.exp(-t)


def dipole(r: ArrayLike, sigma_s_prime: ArrayLike, sigma_a: ArrayLike, eta: float = 1.3) -> FloatArray:
    """Functional form of :class:`Dipole`: R(r), shape ``np.shape(r) + (3,)``."""
    return Dipole(sigma_s_prime, sigma_a, eta)(r)


# ---------------------------------------------------------------------------------------------
# Donner & Jensen 2005 multipole (one slab)

def _cosh_sinh_over_sinh(q: FloatArray, a: FloatArray, b: FloatArray, c: FloatArray) -> FloatArray:
    """cosh(q a) sinh(q b) / sinh(q c) for q >= 0, 0 <= a, 0 <= b, a + b <= c, c > 0: finite for any q
    (exponential form, no overflow), b/c at q = 0 (the limit)."""
    x = q * c
    with np.errstate(over="ignore", under="ignore", invalid="ignore", divide="ignore"):
        def e(t: FloatArray) -> FloatArray:
            return np.exp(np.minimum(t, 0.0))  # arguments are <= 0 up to rounding
        big = 0.5 * (e(q * (a + b - c)) + e(q * (b - a - c)) - e(q * (a - b - c)) - e(-q * (a + b + c)))
        big = big / -np.expm1(-2.0 * x)
        small = np.cosh(q * a) * np.sinh(q * b) / np.sinh(x)
    return np.where(x < 1e-6, b / c, np.where(x < 1.0, small, big))


def _slab_hat_closed(c: _Coefficients, d: float, A_top: float, A_bot: float, q: FloatArray,
                     transmit: bool) -> FloatArray:
    """The image series of eq. (2.65)/(2.67) transformed and summed over all i in closed form.
    sum_i over the images is the 1-D Green's function of g'' - q^2 g = -delta(z - l) with g = 0 at the
    extrapolated boundaries -2 A_top D and d + 2 A_bot D (distance P apart); the sums are its derivatives
    at z = 0 and z = d:  R^(k) = alpha' cosh(q z_b0) sinh(q (d + z_bd - l)) / sinh(q P),
    T^(k) = alpha' cosh(q z_bd) sinh(q (l + z_b0)) / sinh(q P)  (l < d; for l > d the flux at z = d points
    up: T^ = -alpha' cosh(q (d + z_b0)) sinh(q (d + z_bd - l)) / sinh(q P)). Needs l < d + z_bd.
    Used where the series converges too slowly (q P -> 0: sigma_a -> 0 at k = 0)."""
    D = c.D
    l = 1.0 / c.sigma_t_prime
    zb0, zbd = 2.0 * A_top * D, 2.0 * A_bot * D
    P = d + zb0 + zbd
    up = d + zbd - l  # source to the lower extrapolated boundary (> 0)
    if not transmit:
        return c.alpha_prime * _cosh_sinh_over_sinh(q, zb0, up, P)
    below = c.alpha_prime * _cosh_sinh_over_sinh(q, zbd, l + zb0, P)
    above = -c.alpha_prime * _cosh_sinh_over_sinh(q, d + zb0, up, P)
    return np.where(l <= d, below, above)


def _slab_sources(c: _Coefficients, d: float, A_top: float, A_bot: float, n: int) -> tuple[FloatArray, FloatArray]:
    """Source heights below the top surface (z down into the slab), seed 001 eq. (2.60)-(2.63):
    z_r,i = 2 i P + l, z_v,i = 2 i P - l - 4 A_top D, P = d + 2 A_top D + 2 A_bot D, i = -n..n."""
    D = c.D
    l = 1.0 / c.sigma_t_prime
    P = d + 2.0 * A_top * D + 2.0 * A_bot * D
    i = np.arange(-n, n + 1, dtype=np.float64)[:, None]  # (2n+1, 1) against (3,)
    z_r = 2.0 * i * P + l
    z_v = 2.0 * i * P - l - 4.0 * A_top * D
    return z_r, z_v


def _default_n_dipoles(c: _Coefficients, d: float, A_top: float, A_bot: float) -> int:
    # image i contributes ~exp(-2 |i| P sigma_tr): enough images for e^-40, at least 10, at most 400
    P = d + 2.0 * (A_top + A_bot) * c.D
    rate = float(np.min(2.0 * P * c.sigma_tr))
    if rate <= 0:
        return 400
    return int(min(400, max(10, math.ceil(40.0 / rate))))


@dataclass(frozen=True)
class Multipole:
    """Donner & Jensen 2005 multipole for a slab of thickness ``thickness`` (mm), seed 001 eq. (2.65)/(2.67).

    ``eta`` is the slab's index of refraction, ``eta_above``/``eta_below`` those of the media around it
    (A_0 and A_s of eq. 2.63 use the relative indices). ``thickness=inf`` is the dipole.
    ``reflectance``/``transmittance`` are R(r), T(r); ``hankel``/``hankel_transmittance`` their transforms;
    ``flipped()`` is the same slab lit from below (R^-, T^- of eq. 2.73-2.76).
    """
    sigma_s_prime: FloatArray
    sigma_a: FloatArray
    thickness: float
    eta: float = 1.3
    eta_above: float = 1.0
    eta_below: float = 1.0
    n_dipoles: int | None = None

    def __init__(self, sigma_s_prime: ArrayLike, sigma_a: ArrayLike, thickness: float, eta: float = 1.3,
                 eta_above: float = 1.0, eta_below: float = 1.0, n_dipoles: int | None = None):
        c = _coeffs(sigma_s_prime, sigma_a)
        if not (thickness > 0):
            raise ValueError("slab thickness must be > 0 mm (inf for a semi-infinite layer)")
        for e in (eta, eta_above, eta_below):
            if not (e > 0 and math.isfinite(e)):
                raise ValueError("indices of refraction must be positive numbers")
        if n_dipoles is not None and n_dipoles < 0:
            raise ValueError("n_dipoles must be >= 0")
        object.__setattr__(self, "sigma_s_prime", c.sigma_s_prime)
        object.__setattr__(self, "sigma_a", c.sigma_a)
        object.__setattr__(self, "thickness", float(thickness))
        object.__setattr__(self, "eta", float(eta))
        object.__setattr__(self, "eta_above", float(eta_above))
        object.__setattr__(self, "eta_below", float(eta_below))
        object.__setattr__(self, "n_dipoles", n_dipoles)

    @property
    def c(self) -> _Coefficients:
        return _Coefficients(self.sigma_s_prime, self.sigma_a)

    @property
    def A_top(self) -> float:
        return boundary_A(self.eta / self.eta_above)

    @property
    def A_bot(self) -> float:
        return boundary_A(self.eta / self.eta_below)

    @property
    def semi_infinite(self) -> bool:
        return math.isinf(self.thickness)

    def flipped(self) -> Multipole:
        return Multipole(self.sigma_s_prime, self.sigma_a, self.thickness, self.eta,
                         self.eta_below, self.eta_above, self.n_dipoles)

    def _sources(self) -> tuple[FloatArray, FloatArray]:
        n = self.n_dipoles
        if n is None:
            n = _default_n_dipoles(self.c, self.thickness, self.A_top, self.A_bot)
        return _slab_sources(self.c, self.thickness, self.A_top, self.A_bot, n)

    def _as_dipole(self) -> Dipole:
        return Dipole(self.sigma_s_prime, self.sigma_a, self.eta / self.eta_above)

    def reflectance(self, r: ArrayLike) -> FloatArray:
        """Eq. (2.65) with (2.68): alpha'/(4pi) sum_i [f(z_r,i) - f(z_v,i)] in z-down coordinates."""
        if self.semi_infinite:
            return self._as_dipole()(r)
        c, rr = self.c, _r(r)
        z_r, z_v = self._sources()
        s = c.sigma_tr
        acc = np.zeros(np.shape(rr)[:-1] + (3,))
        for zr, zv in zip(z_r, z_v):
            acc += _dipole_term(rr, zr, s) - _dipole_term(rr, zv, s)
        return c.alpha_prime / FOUR_PI * acc

    __call__ = reflectance

    def transmittance(self, r: ArrayLike, form: str = "exact") -> FloatArray:
        """Eq. (2.67) with (2.69): heights (d - z) of the sources above the bottom surface.
        ``form="printed"`` keeps the seed's numerator z_{r,i}, z_{v,i} (see the module notes)."""
        rr = _r(r)
        if self.semi_infinite:
            return np.zeros(np.shape(rr)[:-1] + (3,))
        c, d = self.c, self.thickness
        z_r, z_v = self._sources()
        s = c.sigma_tr
        acc = np.zeros(np.shape(rr)[:-1] + (3,))
        for zr, zv in zip(z_r, z_v):
            if form == "printed":
                hr, hv = d - zr, d - zv
                dr, dv = np.sqrt(rr**2 + hr**2), np.sqrt(rr**2 + hv**2)
                with np.errstate(under="ignore", over="ignore"):
                    acc += (-zr * (1 + s * dr) * np.exp(-s * dr) / dr**3
                            + zv * (1 + s * dv) * np.exp(-s * dv) / dv**3)
            elif form == "exact":
                acc += _dipole_term(rr, d - zr, s) - _dipole_term(rr, d - zv, s)
            else:
                raise ValueError("form must be 'exact' or 'printed'")
        return c.alpha_prime / FOUR_PI * acc

    def _hankel_sum(self, k: ArrayLike, transmit: bool) -> FloatArray:
        """alpha'/(4pi) sum_i [F(z_r,i) - F(z_v,i)] (heights d - z for T). Image i is ~exp(-2|i| P q):
        each k only sums the images that are above e^-40 there (few at large k)."""
        c = self.c
        q = np.sqrt(c.sigma_tr**2 + _r(k) ** 2)  # (..., 3)
        shape = q.shape
        q = q.reshape(-1, 3)
        d = self.thickness
        n = self.n_dipoles
        if n is None:
            n = _default_n_dipoles(c, d, self.A_top, self.A_bot)
        z_r, z_v = _slab_sources(c, d, self.A_top, self.A_bot, n)  # (2n+1, 3), index n is i = 0
        if transmit:
            z_r, z_v = d - z_r, d - z_v
        P = d + 2.0 * (self.A_top + self.A_bot) * c.D
        qmin = q.min(axis=1)
        need = np.ceil(20.0 / np.maximum(np.min(P) * qmin, 1e-300))  # images per k
        order = np.argsort(-need, kind="stable")
        need_sorted = need[order]
        acc = np.zeros_like(q)
        for i in range(n + 1):
            m = int(np.searchsorted(-need_sorted, -i, side="right")) if i > 0 else q.shape[0]
            if m == 0:
                break
            sel = order[:m]
            qq = q[sel]
            for j in ({n + i, n - i} if i else {n}):
                acc[sel] += _dipole_term_hat(qq, z_r[j]) - _dipole_term_hat(qq, z_v[j])
        out = c.alpha_prime / FOUR_PI * acc
        # n images are not enough where q P is small (weak absorption near k = 0: the pairs decay only
        # like q e^(-2 i P q)); unless n was chosen explicitly, those rows take the series' exact sum
        slow = need > n
        if self.n_dipoles is None and np.any(slow) and np.all(1.0 / c.sigma_t_prime < d + 2.0 * self.A_bot * c.D):
            out[slow] = _slab_hat_closed(c, d, self.A_top, self.A_bot, q[slow], transmit)
        return out.reshape(shape)

    def hankel(self, k: ArrayLike) -> FloatArray:
        if self.semi_infinite:
            return self._as_dipole().hankel(k)
        return self._hankel_sum(k, transmit=False)

    def hankel_transmittance(self, k: ArrayLike) -> FloatArray:
        if self.semi_infinite:
            return np.zeros(np.shape(_r(k))[:-1] + (3,))
        return self._hankel_sum(k, transmit=True)

    def total_reflectance(self) -> FloatArray:
        return self.hankel(0.0)

    def total_transmittance(self) -> FloatArray:
        return self.hankel_transmittance(0.0)


# ---------------------------------------------------------------------------------------------
# layered material: combination in frequency space

@dataclass(frozen=True)
class Layer:
    """One layer of a stack: coefficients in 1/mm, thickness in mm (inf: semi-infinite, last only)."""
    sigma_s_prime: tuple[float, float, float]
    sigma_a: tuple[float, float, float]
    thickness: float
    eta: float = 1.4
    name: str = ""


def _inverse_hankel(F: Callable[[FloatArray], FloatArray], r: FloatArray) -> FloatArray:
    """f(r) = 1/(2pi) int_0^inf F(k) J0(k r) k dk for F smooth and decaying in k: composite 8-point
    Gauss-Legendre panels up to where F has decayed (no endpoint error at k = 0, unlike the trapezoid
    rule). Radii are processed by octaves so each group's panels are a quarter of its shortest J0 period."""
    from scipy.special import j0  # here, not at import: scipy costs the viewer's start (issue 34)
    r = np.atleast_1d(np.asarray(r, dtype=float))
    out = np.zeros(r.shape + (3,))
    probe = np.geomspace(1e-3, 1e6, 400)
    Fp = np.max(np.abs(F(probe)) * probe[:, None], axis=1)
    peak = Fp.max()
    if peak <= 0 or r.size == 0:
        return out
    alive = np.nonzero(Fp > 1e-13 * peak)[0]
    k_max = probe[alive[-1]] * 1.5
    x, wx = np.polynomial.legendre.leggauss(8)
    flat, res = r.ravel(), out.reshape(-1, 3)
    order = np.argsort(flat)
    edges = [0.0]
    top = max(float(flat.max()), 1e-9)
    e = max(float(flat[flat > 0].min()) if np.any(flat > 0) else top, 1e-9)
    while e < top:
        e *= 2.0
        edges.append(e)
    edges[-1] = top
    cache: dict[int, tuple[FloatArray, FloatArray]] = {}
    lo = 0
    for hi_r in edges:
        hi = int(np.searchsorted(flat[order], hi_r, side="right"))
        if hi <= lo:
            continue
        idx = order[lo:hi]
        lo = hi
        panels = int(min(50_000, max(64, math.ceil(k_max / (math.pi / (2.0 * max(hi_r, 1e-9)))))))
        if panels not in cache:
            h = k_max / panels
            k = ((np.arange(panels)[:, None] + 0.5 + 0.5 * x[None, :]) * h).ravel()
            w = np.tile(0.5 * h * wx, panels)
            cache[panels] = (k, F(k) * (k * w)[:, None])
        k, Fk = cache[panels]
        step = max(1, 4_000_000 // k.size)
        for a in range(0, idx.size, step):
            sl = idx[a:a + step]
            res[sl] = j0(np.outer(flat[sl], k)) @ Fk
    return out / (2.0 * math.pi)


@dataclass(frozen=True)
class LayeredMultipole:
    """A stack of slabs lit from above, combined with seed 001 eq. (2.73)-(2.82) in frequency space.

    Per interface (layer 1 above layer 2), with hats the 2-D transforms and +/- the direction of the
    incident light (+ from above), the geometric series of eq. (2.80) summed as in (2.81)-(2.82):
      R12+ = R1+ + T1- R2+ T1+ / (1 - R1- R2+)      T12+ = T1+ T2+ / (1 - R1- R2+)
      R12- = R2- + T2+ R1- T2- / (1 - R1- R2+)      T12- = T2- T1- / (1 - R1- R2+)
    The profile in r is the top slab's own R1+(r) (evaluated exactly in r) plus the inverse Hankel
    transform of (R_stack+ - R1+), which decays fast in k because it passes through layer 1 twice.
    """
    layers: tuple[Layer, ...]
    eta_outside: float = 1.0
    eta_below: float = 1.0

    def __init__(self, layers: Sequence[Layer], eta_outside: float = 1.0, eta_below: float = 1.0):
        layers = tuple(layers)
        if not layers:
            raise ValueError("a layered material needs at least one layer")
        for i, L in enumerate(layers):
            if math.isinf(L.thickness) and i != len(layers) - 1:
                raise ValueError("only the last layer can be semi-infinite")
        object.__setattr__(self, "layers", layers)
        object.__setattr__(self, "eta_outside", float(eta_outside))
        object.__setattr__(self, "eta_below", float(eta_below))
        self.slabs()  # validate now

    def slabs(self) -> list[Multipole]:
        out = []
        etas = [self.eta_outside] + [L.eta for L in self.layers] + [self.eta_below]
        for i, L in enumerate(self.layers):
            out.append(Multipole(L.sigma_s_prime, L.sigma_a, L.thickness, L.eta, etas[i], etas[i + 2]))
        return out

    def _combined(self, k: ArrayLike) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
        slabs = self.slabs()
        s0 = slabs[0]
        Rp, Tp = s0.hankel(k), s0.hankel_transmittance(k)
        f = s0.flipped()
        Rm, Tm = f.hankel(k), f.hankel_transmittance(k)
        for s in slabs[1:]:
            R2p, T2p = s.hankel(k), s.hankel_transmittance(k)
            g = s.flipped()
            R2m, T2m = g.hankel(k), g.hankel_transmittance(k)
            inv = 1.0 / (1.0 - Rm * R2p)
            Rp, Tp, Rm, Tm = (Rp + Tm * R2p * Tp * inv, Tp * T2p * inv,
                              R2m + T2p * Rm * T2m * inv, T2m * Tm * inv)
        return Rp, Tp, Rm, Tm

    def hankel(self, k: ArrayLike) -> FloatArray:
        return self._combined(k)[0]

    def hankel_transmittance(self, k: ArrayLike) -> FloatArray:
        return self._combined(k)[1]

    def total_reflectance(self) -> FloatArray:
        return self.hankel(0.0)

    def total_transmittance(self) -> FloatArray:
        return self.hankel_transmittance(0.0)

    def probe_range(self) -> tuple[float, float]:
        """Radii worth probing when choosing a fitting range: beyond 60/sigma_tr of the least absorbing
        layer the profile is below e^-60 of its scale (used by fitting.make_grid)."""
        s = min(float(np.min(L.c.sigma_tr)) for L in self.slabs())
        return 1e-5, (1e4 if s <= 0 else min(1e4, 60.0 / s))

    def __call__(self, r: ArrayLike) -> FloatArray:
        rr = np.abs(np.asarray(r, dtype=np.float64))
        top = self.slabs()[0]
        direct = top.reflectance(rr)
        if len(self.layers) == 1:
            return direct
        flat = rr.ravel()
        rest = _inverse_hankel(lambda k: self.hankel(k) - top.hankel(k), flat)
        return direct + rest.reshape(rr.shape + (3,))


# Illustrative three-layer skin stack (layering as in Donner & Jensen 2005 / seed 002 14.4.3: a thin,
# narrowly scattering epidermis over dermis over a bloody dermis). The seeds do not print DJ2005's
# per-layer coefficients, so: epidermis 0.25 mm thick (the epidermis depth used by DJ2005-style skin
# renderers), high scattering and melanin-like absorption rising towards blue (illustrative values);
# upper dermis 1 mm with Jensen 2001 measured "Skin2"; semi-infinite bloody dermis with Jensen 2001
# measured "Skin1" (../shared/reference/jensen2001_materials.json). eta = 1.4 for all layers.
THREE_LAYER_SKIN: tuple[Layer, ...] = (
    Layer((8.0, 9.0, 10.0), (0.05, 0.15, 0.40), 0.25, 1.4, "epidermis (illustrative)"),
    Layer((1.09, 1.59, 1.79), (0.013, 0.070, 0.145), 1.0, 1.4, "dermis (Jensen 2001 Skin2)"),
    Layer((0.74, 0.88, 1.01), (0.032, 0.17, 0.48), math.inf, 1.4, "bloody dermis (Jensen 2001 Skin1)"),
)


def three_layer_skin() -> LayeredMultipole:
    return LayeredMultipole(THREE_LAYER_SKIN)


# ---------------------------------------------------------------------------------------------
# Burley normalized diffusion

BURLEY_CONFIGS = ("searchlight-mfp", "searchlight-dmfp", "diffuse-transmission")


def burley_scale(albedo: ArrayLike, config: str = "searchlight-dmfp") -> FloatArray:
    """Christensen's fits s(A): eq. (2.86) searchlight + mean free path, (2.88) searchlight + diffuse
    mean free path, (2.89) diffuse surface transmission + mean free path."""
    A = np.asarray(albedo, dtype=np.float64)
    if config == "searchlight-mfp":
        return 1.85 - A + 7.0 * np.abs(A - 0.8) ** 3
    if config == "searchlight-dmfp":
        return 3.5 + 100.0 * (A - 0.33) ** 4
    if config == "diffuse-transmission":
        return 1.9 - A + 3.5 * (A - 0.8) ** 2
    raise ValueError(f"unknown Burley configuration {config!r}; known: {', '.join(BURLEY_CONFIGS)}")


R_FLOOR = 1e-12  # Burley's r floor, in units of d


def burley_normalized(r: ArrayLike, d: ArrayLike) -> FloatArray:
    """Eq. (2.83): R(r) = (e^(-r/d) + e^(-r/(3d))) / (8 pi d r); 2 pi int r R dr = 1.
    ``d`` broadcasts against r (e.g. shape (3,) for RGB with r[..., None]). The 1/r singularity at
    r = 0 is integrable but infinite: r is floored at R_FLOOR * d (1e-12 d: nothing a plot or a fit
    resolves), so the value stays finite."""
    d = np.asarray(d, dtype=np.float64)
    r = np.asarray(np.maximum(np.abs(np.asarray(r, dtype=np.float64)), R_FLOOR * np.where(np.isfinite(d), d, 0.0)))
    with np.errstate(divide="ignore", under="ignore", invalid="ignore"):
        num = np.exp(-r / d) + np.exp(-r / (3.0 * d))
        out = num / (8.0 * math.pi * d * r)
    out = np.nan_to_num(out, nan=0.0, posinf=np.finfo(float).max)  # d below ~1e-140 mm would overflow
    return np.where((d > 0) & np.isfinite(d), out, 0.0)  # d = inf (no absorption): spread to nothing


def diffuse_mean_free_path(sigma_s_prime: ArrayLike, sigma_a: ArrayLike) -> FloatArray:
    """l_d = 1/sigma_tr with D = (sigma_t + sigma_a)/(3 sigma_t^2), sigma_tr = sqrt(sigma_a / D), eq. (2.87).
    Infinite where sigma_a = 0."""
    c = _coeffs(sigma_s_prime, sigma_a)
    st = c.sigma_t_prime
    D = (st + c.sigma_a) / (3.0 * st**2)
    with np.errstate(divide="ignore"):
        return 1.0 / np.sqrt(c.sigma_a / D)


@dataclass(frozen=True)
class Burley:
    """Burley normalized diffusion, eq. (2.84): R(r) = A s (e^(-s r/l) + e^(-s r/(3l))) / (8 pi l r),
    i.e. albedo times eq. (2.83) with d = l/s. ``mfp`` in mm (the diffuse mean free path for
    ``searchlight-dmfp``, the mean free path otherwise)."""
    albedo: FloatArray
    mfp: FloatArray
    config: str = "searchlight-dmfp"

    def __init__(self, albedo: ArrayLike, mfp: ArrayLike, config: str = "searchlight-dmfp"):
        A, l = _rgb(albedo, "albedo"), _rgb(mfp, "mfp")
        if np.any(A < 0) or np.any(A > 1):
            raise ValueError("albedo must be in [0, 1]")
        if np.any(l <= 0):
            raise ValueError("mean free path must be > 0 mm")
        burley_scale(A, config)
        object.__setattr__(self, "albedo", A)
        object.__setattr__(self, "mfp", l)
        object.__setattr__(self, "config", config)

    @property
    def s(self) -> FloatArray:
        return burley_scale(self.albedo, self.config)

    @property
    def d(self) -> FloatArray:
        return self.mfp / self.s

    def __call__(self, r: ArrayLike) -> FloatArray:
        return self.albedo * burley_normalized(_r(r), self.d)

    def total_reflectance(self) -> FloatArray:
        return np.array(self.albedo, dtype=np.float64)

    def min_fit_radius(self) -> float:
        """r R^2 ~ 1/r is not integrable at 0 (eq. 2.83): fits and eq. (3.1) start at d/100
        (the profile holds ~0.5 % of its energy inside that radius, eq. 3.9)."""
        return float(np.min(self.d)) / 100.0

    def cdf(self, r: ArrayLike) -> FloatArray:
        return burley_cdf(_r(r), self.d)

    def sample_radius(self, u: ArrayLike) -> FloatArray:
        """Radii distributed like 2 pi r R(r) / A from uniform u in (0, 1), shape np.shape(u) + (3,)."""
        return burley_inverse_cdf(np.asarray(u, dtype=np.float64)[..., None], self.d)


def burley_cdf(r: ArrayLike, d: ArrayLike = 1.0) -> FloatArray:
    """Eq. (3.9) with s = 1/d: P(r) = 1 - e^(-r/d)/4 - 3 e^(-r/(3d))/4 (expm1 form, exact near 0)."""
    x = np.abs(np.asarray(r, dtype=np.float64)) / np.asarray(d, dtype=np.float64)
    return -(0.25 * np.expm1(-x) + 0.75 * np.expm1(-x / 3.0))


def burley_ccdf(r: ArrayLike, d: ArrayLike = 1.0) -> FloatArray:
    """u = 1 - P(r) = e^(-r/d)/4 + 3 e^(-r/(3d))/4 (exact in the tail)."""
    x = np.abs(np.asarray(r, dtype=np.float64)) / np.asarray(d, dtype=np.float64)
    with np.errstate(under="ignore"):
        return 0.25 * np.exp(-x) + 0.75 * np.exp(-x / 3.0)


def burley_inverse_cdf(u: ArrayLike, d: ArrayLike = 1.0, printed: bool = False) -> FloatArray:
    """Analytic inverse, eq. (3.12)-(3.13): the radius r with 1 - P(r) = u (u uniform in (0, 1] gives
    samples of the profile; u and 1-u are equally uniform).
      G(u) = 1 + 4u (2u + sqrt(1 + 4u^2)),  r/d = 3 log((1 + G^(-1/3) + G^(1/3)) / (4u)).
    u is clamped to [tiny, 1]: u -> 0 gives a large finite radius (~2100 d), u = 1 gives 0.
    ``printed=True`` evaluates the seed's printed (1 + 2 G^(-1/3)) form, which is not an inverse."""
    u = np.asarray(np.clip(np.asarray(u, dtype=np.float64), np.finfo(float).tiny, 1.0))
    G = 1.0 + 4.0 * u * (2.0 * u + np.sqrt(1.0 + 4.0 * u * u))
    g = np.cbrt(G)
    num = 1.0 + (2.0 / g if printed else 1.0 / g + g)
    # log(num/(4u)) = log(num/4) - log(u): finite for tiny u
    x = 3.0 * (np.log(num / 4.0) - np.log(u))
    return np.maximum(x, 0.0) * np.asarray(d, dtype=np.float64)


# ---------------------------------------------------------------------------------------------
# measured data

@dataclass(frozen=True)
class Material:
    sigma_s_prime: tuple[float, float, float]  # 1/mm
    sigma_a: tuple[float, float, float]  # 1/mm
    eta: float = 1.3

    def dipole(self) -> Dipole:
        return Dipole(self.sigma_s_prime, self.sigma_a, self.eta)


# Jensen, Marschner, Levoy, Hanrahan: "A Practical Model for Subsurface Light Transport",
# SIGGRAPH 2001, measured parameters (Figure 5), RGB, 1/mm, eta = 1.3.
MATERIALS: dict[str, Material] = {
    "Apple": Material((2.29, 2.39, 1.97), (0.0030, 0.0034, 0.046)),
    "Chicken1": Material((0.15, 0.21, 0.38), (0.015, 0.077, 0.19)),
    "Chicken2": Material((0.19, 0.25, 0.32), (0.018, 0.088, 0.20)),
    "Cream": Material((7.38, 5.47, 3.15), (0.0002, 0.0028, 0.0163)),
    "Ketchup": Material((0.18, 0.07, 0.03), (0.061, 0.97, 1.45)),
    "Marble": Material((2.19, 2.62, 3.00), (0.0021, 0.0041, 0.0071)),
    "Potato": Material((0.68, 0.70, 0.55), (0.0024, 0.0090, 0.12)),
    "Skimmilk": Material((0.70, 1.22, 1.90), (0.0014, 0.0025, 0.0142)),
    "Skin1": Material((0.74, 0.88, 1.01), (0.032, 0.17, 0.48)),
    "Skin2": Material((1.09, 1.59, 1.79), (0.013, 0.070, 0.145)),
    "Spectralon": Material((11.6, 20.4, 14.9), (0.0, 0.0, 0.0)),
    "Wholemilk": Material((2.55, 3.21, 3.77), (0.0011, 0.0024, 0.014)),
}


def material(name: str) -> Material:
    """Case-insensitive lookup in MATERIALS; KeyError names the known materials."""
    for k, v in MATERIALS.items():
        if k.lower() == name.strip().lower():
            return v
    raise KeyError(f"unknown material {name!r}; known: {', '.join(MATERIALS)}")


# d'Eon & Luebke 2007 (GPU Gems 3 ch. 14; seed 000 Tabela 2; seed 004): six Gaussians fit to the
# three-layer skin model of Donner & Jensen 2005. (variance mm^2, (w_r, w_g, w_b)); variances shared.
DEON_SKIN_GAUSSIANS: tuple[tuple[float, tuple[float, float, float]], ...] = (
    (0.0064, (0.233, 0.455, 0.649)),
    (0.0484, (0.100, 0.336, 0.344)),
    (0.187, (0.118, 0.198, 0.000)),
    (0.567, (0.113, 0.007, 0.007)),
    (1.99, (0.358, 0.004, 0.000)),
    (7.41, (0.078, 0.000, 0.000)),
)


def gaussian(v: ArrayLike, r: ArrayLike) -> FloatArray:
    """G(v, r) = exp(-r^2/(2v)) / (2 pi v), seed 000 eq. (20): unit integral over the plane.
    The one implementation is :func:`skinviewer.physics.diffusion.gaussian` (v <= 0 -> 0, never Inf)."""
    return _diffusion_gaussian(v, r)


def sum_of_gaussians(r: ArrayLike, variances: ArrayLike, weights: ArrayLike) -> FloatArray:
    """R(r) = sum_i w_i G(v_i, r), seed 000 eq. (21).

    ``variances`` (k,) shared with ``weights`` (k, 3) -> shape np.shape(r) + (3,);
    ``weights`` (k,) -> np.shape(r); per-channel ``variances`` (3, k) with ``weights`` (3, k) -> (..., 3).
    """
    v = np.asarray(variances, dtype=np.float64)
    w = np.asarray(weights, dtype=np.float64)
    r = np.asarray(r, dtype=np.float64)
    if v.ndim == 1 and w.ndim == 1:
        return np.tensordot(gaussian(v, r[..., None]), w, axes=([-1], [0]))
    if v.ndim == 1 and w.ndim == 2:
        return gaussian(v, r[..., None]) @ w
    if v.ndim == 2 and w.shape == v.shape:
        out: FloatArray = np.einsum("...ck,ck->...c", gaussian(v, r[..., None, None]), w)
        return out
    raise ValueError("variances (k,) with weights (k,) or (k, 3); or variances and weights both (3, k)")


def deon_skin_profile(r: ArrayLike) -> FloatArray:
    """The d'Eon six-Gaussian skin profile as R(r), shape np.shape(r) + (3,)."""
    v = np.array([g[0] for g in DEON_SKIN_GAUSSIANS])
    w = np.array([g[1] for g in DEON_SKIN_GAUSSIANS])
    return sum_of_gaussians(r, v, w)
